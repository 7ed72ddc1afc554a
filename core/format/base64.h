/* base64.h -- RFC 4648 base64 decoding (internal). */
#ifndef BASE64_H
#define BASE64_H

#include <stddef.h>

#include "rayd/rayd.h"

/* Decodes in[0..len) (need not be NUL-terminated), standard alphabet
 * A-Z a-z 0-9 + /.  Padding '=' is optional but, when present, must be
 * right; spaces, tabs and line breaks anywhere are ignored.  On RAYD_OK
 * *out owns a malloc'd buffer of *out_len bytes (never NULL, even for empty
 * input; free it with free).  Otherwise RAYD_E_INVALID with the offset of
 * the offending character in err, or RAYD_E_NOMEM, and *out, *out_len are
 * untouched. */
enum rayd_status base64_decode(const char *in, size_t len, unsigned char **out, size_t *out_len,
                               struct rayd_error *err);

#endif
