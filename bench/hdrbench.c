/* hdrbench.c -- the HDR encoders against the 8-bit PNG on one frame.
 *
 * Renders SCENE (its own size and samples) once into an accumulator, then
 * times, as medians of RUNS: the resolves (8-bit image, linear floats) and
 * the encodes -- the 8-bit PNG (rayd's band encoder, THREADS threads), the
 * 16-bit PNG (libpng, one thread) and OpenEXR (OpenEXRCore: PIZ where
 * the floats repeat, else none; one thread) -- and prints each file's size.
 *
 *   build/bench/hdrbench SCENE.json [THREADS]
 */
#include <rayd/rayd.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define RUNS 5

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

enum what { W_IMAGE, W_LINEAR, W_PNG8, W_PNG16, W_EXR, W__COUNT };
static const char *const names[W__COUNT] = {"resolve 8-bit", "resolve float", "encode png 8-bit",
                                            "encode png16", "encode exr"};

/* One timed run of w; *size gets the bytes written (0 for resolves). */
static double run(enum what w, const rayd_accum *acc, const rayd_image *img, const float *lin,
                  int threads, size_t *size) {
    struct rayd_region r = rayd_accum_region(acc);
    void *buf = NULL;
    size_t len = 0;
    rayd_image *tmp = NULL;
    float *f = NULL;
    double t = now();
    enum rayd_status st = RAYD_OK;
    switch (w) {
    case W_IMAGE: st = rayd_accum_image(acc, &tmp, NULL); break;
    case W_LINEAR: st = rayd_accum_linear(acc, &f, NULL); break;
    case W_PNG8: st = rayd_png_encode_threads(img, -1, threads, &buf, &len, NULL); break;
    case W_PNG16: st = rayd_png16_encode(lin, r.w, r.h, -1, &buf, &len, NULL); break;
    default: st = rayd_exr_encode(lin, r.w, r.h, &buf, &len, NULL); break;
    }
    t = now() - t;
    if (st != RAYD_OK) fprintf(stderr, "hdrbench: %s failed\n", names[w]), exit(1);
    rayd_image_free(tmp);
    rayd_free(f);
    rayd_free(buf);
    *size = len;
    return t;
}

int main(int argc, char **argv) {
    if (argc < 2) return fprintf(stderr, "usage: hdrbench SCENE.json [THREADS]\n"), 2;
    int threads = argc > 2 ? atoi(argv[2]) : 2;
    char *text = NULL;
    size_t len = 0;
    rayd_scene *s = NULL;
    rayd_accum *acc = NULL;
    struct rayd_scene_info info;
    if (rayd_read_file(argv[1], (size_t)1 << 30, &text, &len, NULL) != RAYD_OK ||
        rayd_scene_parse(text, len, NULL, &s, NULL) != RAYD_OK)
        return fprintf(stderr, "hdrbench: cannot load %s\n", argv[1]), 1;
    rayd_scene_info(s, &info);
    struct rayd_render_opts o = {.threads = threads};
    rayd_image *img = NULL;
    float *lin = NULL;
    if (rayd_accum_new(s, NULL, &acc, NULL) != RAYD_OK ||
        rayd_render_pass(s, &o, acc, 0, info.samples, NULL) != RAYD_OK ||
        rayd_accum_image(acc, &img, NULL) != RAYD_OK ||
        rayd_accum_linear(acc, &lin, NULL) != RAYD_OK)
        return fprintf(stderr, "hdrbench: render failed\n"), 1;
    printf("%s: %dx%d, %d samples; 8-bit PNG on %d threads, the others on one\n", argv[1],
           info.width, info.height, info.samples, threads);
    for (int w = 0; w < W__COUNT; w++) {
        double t[RUNS];
        size_t size = 0;
        for (int k = 0; k < RUNS; k++) t[k] = run((enum what)w, acc, img, lin, threads, &size);
        qsort(t, RUNS, sizeof *t, cmp);
        printf("%-18s %8.1f ms", names[w], t[RUNS / 2] * 1e3);
        if (size) printf("  %9zu bytes", size);
        printf("\n");
    }
    rayd_free(lin);
    rayd_image_free(img);
    rayd_accum_free(acc);
    rayd_scene_free(s);
    free(text);
    return 0;
}
