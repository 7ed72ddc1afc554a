/* exr_imf.h -- OpenEXR in through the format's C++ library (exr_imf.cc). */
#ifndef EXR_IMF_H
#define EXR_IMF_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Decodes the first part of the OpenEXR file buf (len bytes) into rgb,
 * w x h x 3 floats from the data window's top-left corner (w and h are the
 * data window's size, already checked against the limits); a channel the
 * file lacks reads 0.  0 on success; else -1 and message says why. */
int exr_imf_read_rgb(const void *buf, size_t len, float *rgb, int w, int h, char *message,
                     size_t message_size);

#ifdef __cplusplus
}
#endif

#endif
