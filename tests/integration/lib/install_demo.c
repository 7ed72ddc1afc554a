/* install_demo.c -- a program built the way a user of an installed librayd
 * builds one, by tests/integration/install.sh: compiled with nothing but
 * `pkg-config --cflags --libs rayd` against the installed header and library
 * (never by the Makefile, so it sees no file of the source tree).
 *
 *   install_demo SCENE.json OUT.png
 *
 * Renders the scene through the public API on two threads, writes the PNG,
 * and prints "RAYD_VERSION WIDTH HEIGHT" so the test can check the version
 * the installed header carries.  Frees everything, so a sanitized build's
 * leak check stays quiet.  Exit status 0 on success, 1 with the error.
 */
#include <rayd/rayd.h>

#include <stdio.h>

static int fail(const char *what, const struct rayd_error *err) {
    char msg[600];
    fprintf(stderr, "install_demo: %s: %s (%s)\n", what, rayd_error_format(err, msg, sizeof msg),
            rayd_status_name(err->code));
    return 1;
}

int main(int argc, char **argv) {
    if (argc != 3) {
        fprintf(stderr, "usage: install_demo SCENE.json OUT.png\n");
        return 1;
    }
    struct rayd_error err;
    char *text = NULL;
    size_t len = 0;
    if (rayd_read_file(argv[1], 1 << 24, &text, &len, &err) != RAYD_OK) return fail("read", &err);

    rayd_scene *scene = NULL;
    enum rayd_status st = rayd_scene_parse(text, len, NULL, &scene, &err);
    rayd_free(text);
    if (st != RAYD_OK) return fail("parse", &err);

    struct rayd_render_opts opts = {.threads = 2};
    rayd_image *img = NULL;
    st = rayd_render(scene, &opts, &img, &err);
    rayd_scene_free(scene);
    if (st != RAYD_OK) return fail("render", &err);

    st = rayd_png_write_file(img, argv[2], &err);
    int w = rayd_image_width(img), h = rayd_image_height(img);
    rayd_image_free(img);
    if (st != RAYD_OK) return fail("write", &err);
    printf("%s %d %d\n", RAYD_VERSION, w, h);
    return 0;
}
