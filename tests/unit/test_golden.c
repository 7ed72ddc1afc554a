/* test_golden.c -- the example scenes against stored images.
 *
 * tests/scenes/NAME.json is rendered and compared with tests/golden/NAME.png.
 * Tolerance: rendering is deterministic, so on one build the bytes are
 * equal; across compilers and libm versions the last bit of pow() or sqrt()
 * may move a channel by a level or two, and a grazing ray may flip a pixel.
 * So a channel may differ by at most 2 levels, except at most 0.1% of
 * channels, which may differ by at most 64.  `make golden` rewrites the
 * stored images after an intended change; look at them before committing.
 */
#include <dirent.h>
#include <stdlib.h>

#include "check.h"
#include "scene_util.h"

static int compare(const char *name) {
    char path[512];
    size_t len = 0;
    snprintf(path, sizeof path, "tests/scenes/%s.json", name);
    char *text = read_file(path, &len);
    snprintf(path, sizeof path, "tests/golden/%s.png", name);
    size_t plen = 0;
    char *png = read_file(path, &plen);
    int ok = 0;
    rayd_scene *s = NULL;
    rayd_image *got = NULL, *want = NULL;
    struct rayd_error err = {0};
    if (!text || !png) {
        printf("  %s: missing scene or golden image (make golden)\n", name);
    } else if (rayd_scene_parse(text, len, NULL, &s, &err) != RAYD_OK ||
               rayd_png_decode(png, plen, 0, &want, &err) != RAYD_OK || !(got = render_all(s, 2))) {
        printf("  %s: %s\n", name, err.message);
    } else if (rayd_image_width(got) != rayd_image_width(want) ||
               rayd_image_height(got) != rayd_image_height(want)) {
        printf("  %s: size differs from the golden image\n", name);
    } else {
        size_t n = (size_t)rayd_image_width(got) * rayd_image_height(got) * 3, over2 = 0;
        int worst = 0;
        const uint8_t *a = rayd_image_pixels_const(got), *b = rayd_image_pixels_const(want);
        for (size_t i = 0; i < n; i++) {
            int d = abs(a[i] - b[i]);
            over2 += d > 2;
            worst = d > worst ? d : worst;
        }
        ok = over2 * 1000 <= n && worst <= 64;
        if (!ok) printf("  %s: %zu channels off by > 2, worst %d\n", name, over2, worst);
    }
    rayd_image_free(got);
    rayd_image_free(want);
    rayd_scene_free(s);
    free(text);
    free(png);
    return ok;
}

int main(void) {
    DIR *d = opendir("tests/scenes");
    int count = 0;
    struct dirent *e;
    while (d && (e = readdir(d))) {
        size_t n = strlen(e->d_name);
        if (n < 6 || strcmp(e->d_name + n - 5, ".json") != 0) continue;
        char name[256];
        snprintf(name, sizeof name, "%.*s", (int)(n - 5), e->d_name);
        int before = check_failures_;
        CHECK(compare(name), "golden %s", name);
        printf("%s golden_%s\n", check_failures_ == before ? "PASS" : "FAIL", name);
        count++;
    }
    if (d) closedir(d);
    CHECK(count >= 3, "found %d golden scenes", count);
    CHECK_EXIT();
}
