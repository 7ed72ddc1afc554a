/* output_kind.c -- what an output file's name asks for.
 *
 * rayd-render and rayd-client choose the format they write from the
 * output's extension when no --format is given: .exr is OpenEXR, anything
 * else PNG.  A name that ends in another image format's extension (-o
 * frame.jpg) would then get PNG bytes under a name that promises JPEG,
 * which viewers and upload forms refuse or misread; so such a name is
 * refused by the programs instead, with this list.  Case is ignored
 * (.EXR is OpenEXR).  It is the programs' concern, not the core's: the
 * core encodes what it is asked to and never names a file it writes, and
 * the server takes the format from the request (?format=exr).
 */
#include "common/common.h"

#include <stddef.h>
#include <string.h>
#include <strings.h>

/* Extensions of image formats rayd does not write. */
static const char *const other_images[] = {
    ".jpg", ".jpeg", ".jpe", ".jfif", ".webp", ".gif",  ".bmp",  ".tif", ".tiff", ".tga",
    ".ppm", ".pgm",  ".pnm", ".pbm",  ".hdr",  ".avif", ".heic", ".jxl", ".qoi",  ".ico"};

static const char *extension(const char *path) {
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    return dot && (!slash || dot > slash) ? dot : "";
}

const char *output_kind(const char *path) {
    const char *ext = extension(path);
    if (!strcasecmp(ext, ".exr")) return "exr";
    for (size_t i = 0; i < sizeof other_images / sizeof *other_images; i++)
        if (!strcasecmp(ext, other_images[i])) return NULL;
    return "png";
}

bool output_kind_exr(const char *path) {
    const char *kind = output_kind(path);
    return kind && !strcmp(kind, "exr");
}
