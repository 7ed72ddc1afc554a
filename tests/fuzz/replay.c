/* replay.c -- runs a fuzz target over files, without libFuzzer.
 *
 * Linked with one tests/fuzz/fuzz_*.c, it feeds every file named on the
 * command line to LLVMFuzzerTestOneInput once.  `make test` builds it with
 * gcc (and under ASan+UBSan with SANITIZE=1) and replays the seed corpus and
 * every crash ever found (tests/fuzz/regressions/), so a fixed crash stays
 * fixed even where clang's libFuzzer is not installed.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int main(int argc, char **argv) {
    int failed = 0;
    for (int i = 1; i < argc; i++) {
        FILE *f = fopen(argv[i], "rb");
        if (!f) {
            printf("FAIL replay %s: cannot open\n", argv[i]);
            failed = 1;
            continue;
        }
        fseek(f, 0, SEEK_END);
        long n = ftell(f);
        fseek(f, 0, SEEK_SET);
        uint8_t *buf = malloc(n > 0 ? (size_t)n : 1);
        size_t got = buf ? fread(buf, 1, (size_t)n, f) : 0;
        fclose(f);
        LLVMFuzzerTestOneInput(buf, got);
        free(buf);
        printf("PASS replay %s\n", argv[i]);
    }
    return failed;
}
