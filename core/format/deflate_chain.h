/* deflate_chain.h -- a whole raw deflate stream made into one that another
 * stream may follow (internal; see deflate_chain.c). */
#ifndef DEFLATE_CHAIN_H
#define DEFLATE_CHAIN_H

#include <stddef.h>

/* Bytes that deflate_chain may add to a stream: an empty stored block. */
#define DEFLATE_CHAIN_EXTRA 5

/* buf[0..len) is one complete raw deflate stream (RFC 1951) with nothing
 * after its final block but zero padding.  Rewrites it in place so that it
 * no longer ends the data: the final block's BFINAL bit is cleared and an
 * empty stored block follows, ending on a byte boundary (what zlib writes
 * for a sync flush), so another raw deflate stream may simply follow its
 * bytes.  cap >= len + DEFLATE_CHAIN_EXTRA is room enough.  Returns the new
 * length, or 0 when buf is not one well-formed stream (buf then unchanged)
 * or cap is too small. */
size_t deflate_chain(unsigned char *buf, size_t len, size_t cap);

#endif
