/* exr_chans.h -- the channels rayd's EXR files hold, shared by the writer
 * (exr.c) and the reader (exr_read.c), so a file read back lands each
 * channel where the writer took it from. */
#ifndef EXR_CHANS_H
#define EXR_CHANS_H

#include <stddef.h>

/* A channel of the file: its name, and where its floats are (the pixel
 * of the RGB or of the AOVs, at offset `at`). */
struct exr_chan {
    const char *name;
    unsigned aov; /* 0: the RGB; else its RAYD_AOV_ bit */
    int at;
};

extern const struct exr_chan exr_chans[]; /* R, G, B, then the AOVs' */
extern const size_t exr_nchans;

#endif
