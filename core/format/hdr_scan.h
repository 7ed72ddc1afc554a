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

#endif
