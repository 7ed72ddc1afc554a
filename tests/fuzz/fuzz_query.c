/* fuzz_query.c -- libFuzzer target: the region query parser (api_region)
 * of the image routes, on query strings as they arrive after "?".
 *
 * The first input byte picks the image size (1..64 x 1..48) and, with its
 * high bit, POST /v1/render's parser (api_target: format and sample ranges
 * too); the rest is the raw query string, percent-decoded as libmicrohttpd
 * does.  An accepted region must lie inside the image with w, h >= 1, an
 * accepted sample range inside the scene's samples; a refused one must be
 * a 400 bad_region or bad_parameter.  Anything else aborts.
 */
#include "fuzz_http_common.h"

#include <stdio.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static rayd_scene *fq_scenes[16];

static void fq_init(void) {
    static int done;
    if (done) return;
    done = 1;
    char *argv[] = {"fuzz_query", NULL};
    if (config_load(1, argv)) abort();
    log_quiet = true;
    for (int i = 0; i < 16; i++) {
        char json[400];
        snprintf(json, sizeof json,
                 "{\"camera\": {\"position\": [0, 0, 5], \"look_at\": [0, 0, 0], \"fov_x\": 40},"
                 " \"render\": {\"width\": %d, \"height\": %d, \"samples\": 7},"
                 " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1}]}",
                 1 + i * 4 + (i == 15 ? 3 : 0), 1 + i * 3 + (i == 15 ? 2 : 0));
        if (rayd_scene_parse(json, strlen(json), NULL, &fq_scenes[i], NULL) != RAYD_OK) abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    fq_init();
    if (size < 1) return 0;
    const rayd_scene *scene = fq_scenes[data[0] % 16];
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    static struct fh_req q;
    memset(&q, 0, sizeof q);
    fh_parse_query(&q, (const char *)data + 1, size - 1);
    struct http_req *r = http_req_new(&fh_io, &q, "GET", "/v1/scenes/x/image.png", size + 20);
    if (!r) abort();
    struct rayd_region reg = {-7, -7, -7, -7};
    struct work_target what = {.k0 = -7};
    bool target = data[0] & 0x80;
    bool ok = target ? api_target(r, scene, &what) : api_region(r, scene, &reg);
    if (ok && target) {
        reg = what.reg;
        if (what.format == WORK_SUMS && (what.k0 < 0 || what.k1 <= what.k0 || what.k1 > 7)) {
            fprintf(stderr, "fuzz_query: accepted samples %d-%d of 7\n", what.k0, what.k1);
            abort();
        }
    }
    if (ok) {
        if (r->conn.pending || reg.x < 0 || reg.y < 0 || reg.w < 1 || reg.h < 1 ||
            (long)reg.x + reg.w > info.width || (long)reg.y + reg.h > info.height) {
            fprintf(stderr, "fuzz_query: accepted %d,%d,%d,%d of %dx%d\n", reg.x, reg.y, reg.w,
                    reg.h, info.width, info.height);
            abort();
        }
    } else if (r->res.status != 400 || !r->res.err_code ||
               (strcmp(r->res.err_code, "bad_region") &&
                strcmp(r->res.err_code, "bad_parameter"))) {
        fprintf(stderr, "fuzz_query: refused with %d %s\n", r->res.status,
                r->res.err_code ? r->res.err_code : "(none)");
        abort();
    }
    http_flow_end(r, NULL);
    fh_free(&q);
    return 0;
}
