/* hdr_scan.h -- a Radiance .hdr's pixel data checked before decoding
 * (hdr_scan.c). */
#ifndef HDR_SCAN_H
#define HDR_SCAN_H

#include <stdbool.h>
#include <stddef.h>

/* True when the w x h pixel data of the .hdr in b[0..len) is all there,
 * walked as stb_image's decoder walks it; otherwise false, with why (n
 * bytes) saying in which row it ends.
 * The header must already have been read (stbi_info) and w, h > 0. */
bool hdr_scan(const unsigned char *b, size_t len, int w, int h, char *why, size_t n);

/* Why stb_image cannot read the header of the .hdr in b[0..len): lines
 * ending in CR LF, no FORMAT=32-bit_rle_rgbe line, a header without its
 * empty line, a resolution line other than "-Y H +X W".  True with why
 * (n bytes) when one of these is it; false when the header is none of
 * them (stb's own reason stands). */
bool hdr_header_why(const unsigned char *b, size_t len, char *why, size_t n);

#endif
