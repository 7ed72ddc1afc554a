/* output.c -- where rayd-client puts the finished image.
 *
 * `-o FILE` is written as FILE.part and then renamed, so a reader (or a
 * script that checks for the file) never sees half an image, and a failed
 * run leaves no file behind.  `-o -` writes the bytes to standard output,
 * as `rayd-render -o -` does; every status line of the client goes to
 * stderr, so the image is the only thing on stdout then.
 */
#include "client.h"

#include <rayd/rayd.h>

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *output_name(const char *path)
{
    return strcmp(path, "-") ? path : "standard output";
}

bool output_is_exr(const char *path)
{
    const char *kind = rayd_output_kind(path);
    return kind && !strcmp(kind, "exr");
}

static int output_stdout(const void *buf, size_t len)
{
    if (fwrite(buf, 1, len, stdout) == len && fflush(stdout) == 0)
        return 0;
    fprintf(stderr, "rayd-client: error: cannot write standard output: %s\n", strerror(errno));
    return -1;
}

int output_write(const char *path, const void *buf, size_t len)
{
    if (!strcmp(path, "-"))
        return output_stdout(buf, len);
    size_t n = strlen(path) + 8;
    char *tmp = malloc(n);
    if (!tmp) {
        fprintf(stderr, "rayd-client: error: out of memory\n");
        return -1;
    }
    snprintf(tmp, n, "%s.part", path);
    FILE *f = fopen(tmp, "wb");
    int ok = f && fwrite(buf, 1, len, f) == len;
    if (f && fclose(f) != 0)
        ok = 0;
    if (!ok || rename(tmp, path) != 0) {
        fprintf(stderr, "rayd-client: error: cannot write %s: %s\n", path, strerror(errno));
        remove(tmp);
        free(tmp);
        return -1;
    }
    free(tmp);
    return 0;
}
