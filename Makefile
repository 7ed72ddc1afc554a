# rayd -- build, test, bench, deps, run.
#
#   make             build/librayd.a, build/rayd-render, build/rayd, build/rayd-client
#   make test        every test; ends with "N passed, N failed"
#   make test SANITIZE=1   the same suite built with ASan+UBSan into build/asan/
#   make test-tsan   server + job queue integration tests under ThreadSanitizer (build/tsan/)
#   make test-valgrind  three server integration tests with rayd under valgrind memcheck
#   make test-stress the integration tests loaded, on one core, and twice idle
#   make run         build and start rayd on 127.0.0.1:8080 with the preview
#   make deps        install the Debian packages the build and the tests need
#   make bench       benchmarks (never part of make test)
#   make bench-peers the same meshes and sphere scene with Embree and POV-Ray (make bench-deps)
#   make check-layers  includes and calls one way down the layers, no circles
#                    (tools/check_layers.py; part of make test)
#   make format      clang-format every C file;  make lint  cppcheck + clang-tidy

# Debian packages: compiler and tools, the three given libraries, libcurl for
# the client, libssl (libcrypto's SHA-256 of scene ids, server and client), curl/python3/nginx for the
# integration tests (nginx balances the scale-out test), wrk for benchmarks,
# chromium (and a font) for the browser tests of the preview page, valgrind
# (make test-valgrind), openssl (a test certificate for the TLS test), libisal
# and zlib (the PNG encoder's deflates, core/io/png_encode.c) and pngcheck (the tests
# check the encoder's files with it), libopenexr-dev (EXR out, core/io/exr.c)
# and openexr (its exrheader; g++ builds the tests' EXR reader on OpenEXR's
# C++ library), assimp-testmodels (real model files others made, read by
# the tests), python3-prometheus-client (its parser reads /metrics in
# tests/integration/observability.sh).
DEB_PKGS := gcc make pkg-config libc6-dev libpng-dev zlib1g-dev libcjson-dev libmicrohttpd-dev \
            libcurl4-openssl-dev libssl-dev curl python3 nginx wrk chromium fonts-dejavu-core pngcheck \
            clang libclang-rt-14-dev valgrind openssl libopenexr-dev openexr g++ libisal-dev \
            assimp-testmodels python3-prometheus-client

SUDO := $(if $(filter 0,$(shell id -u)),,sudo)

# Build on every core unless told otherwise (tests themselves run one by one).
ifeq ($(MAKELEVEL)$(filter -j%,$(MAKEFLAGS)),0)
MAKEFLAGS += -j$(shell nproc 2>/dev/null || echo 2)
endif

CC ?= cc
ifeq ($(origin CC),default)
CC := cc
endif

SANITIZE ?= 0
TSAN ?= 0
NATIVE ?= 0

ifeq ($(SANITIZE),1)
BUILD ?= build/asan
OPT := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all
LDSAN := -fsanitize=address,undefined
else ifeq ($(TSAN),1)
BUILD ?= build/tsan
OPT := -O1 -g -fno-omit-frame-pointer -fsanitize=thread
LDSAN := -fsanitize=thread
else
BUILD ?= build
OPT := -O2 -g -fno-math-errno
LDSAN :=
endif
ifeq ($(NATIVE),1)
OPT += -march=native
endif

WARN := -Wall -Wextra -Werror -Wshadow -Wpointer-arith -Wstrict-prototypes \
        -Wmissing-prototypes -Wvla -Wformat=2 -Wundef -Wcast-qual -Wnull-dereference
# -ffp-contract=off: no fused multiply-add behind our back (clang fuses by
# default), so the one-ray code and the packets do the same roundings.
CFLAGS_ALL := -std=c11 -D_POSIX_C_SOURCE=200809L -ffp-contract=off $(OPT) $(WARN) -MMD -MP $(CFLAGS)
LDFLAGS_ALL := $(LDSAN) $(LDFLAGS)
# OpenEXR (core/io/exr.c only) through pkg-config; recursively expanded, so
# pkg-config runs in recipes, after `make deps` has installed it.
EXR_CFLAGS = $(patsubst -I%,-isystem %,$(shell pkg-config --cflags OpenEXR))
EXR_LIBS = $(shell pkg-config --libs OpenEXR)
LIBS_CORE = -lpng -lz -lisal -lcjson $(EXR_LIBS) -lpthread -lm

CORE_SRC := $(wildcard core/*/*.c)
CORE_OBJ := $(CORE_SRC:%.c=$(BUILD)/%.o)
SERVER_SRC := $(wildcard server/*.c)
SERVER_OBJ := $(SERVER_SRC:%.c=$(BUILD)/%.o)
SERVER_HDR := $(wildcard server/*.h)
WEB_FILES := $(wildcard server/web/*)
CLIENT_SRC := $(wildcard clients/*.c)
UNIT_SRC := $(wildcard tests/unit/test_*.c)
UNIT_BIN := $(UNIT_SRC:tests/unit/%.c=$(BUILD)/tests/%)
FUZZ_TARGETS := $(patsubst tests/fuzz/fuzz_%.c,%,$(wildcard tests/fuzz/fuzz_*.c))
FUZZ_REPLAY := $(FUZZ_TARGETS:%=$(BUILD)/tests/fuzz/replay_%)

PROGS := $(BUILD)/rayd-render
ifneq ($(SERVER_SRC),)
PROGS += $(BUILD)/rayd
endif
ifneq ($(CLIENT_SRC),)
PROGS += $(BUILD)/rayd-client
endif

.PHONY: all deps check-layers test test-unit test-stress test-tsan test-valgrind golden run bench bench-deps bench-peers format lint clean
.DEFAULT_GOAL := all

all: $(BUILD)/librayd.a $(PROGS)

# --- dependencies ---------------------------------------------------------
# `make deps` installs what is missing (apt-get update once, then only the
# missing packages).  Every build runs the cheap check first.
deps:
	@missing=""; for p in $(DEB_PKGS); do \
	  dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q '^install ok installed' || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "make deps: installing$$missing"; \
	  $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	fi

$(BUILD)/.deps-ok: Makefile
	@$(MAKE) --no-print-directory deps
	@mkdir -p $(BUILD) && touch $@

# --- core -------------------------------------------------------------------
$(BUILD)/%.o: %.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude -c $< -o $@

# server/ and clients/ see only include/: the core's internals stay private.
$(BUILD)/server/%.o: server/%.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -D_DEFAULT_SOURCE -Iinclude -I$(BUILD)/server -c $< -o $@

$(BUILD)/clients/%.o: clients/%.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -D_DEFAULT_SOURCE -Iinclude -c $< -o $@

$(BUILD)/core/%.o: core/%.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) $(CFLAGS_VEC) -Iinclude -Icore -c $< -o $@

# Loops over a packet's lanes (integrate_wide.c, camera.c) and the PNG row
# filters (png_encode.c) are written for the vectoriser, which -O2 runs only
# on the cheapest loops.
$(BUILD)/core/render/integrate_wide.o $(BUILD)/core/geom/camera.o $(BUILD)/core/io/png_encode.o: CFLAGS_VEC := -ftree-vectorize \
    -fvect-cost-model=dynamic

$(BUILD)/core/io/exr.o: CFLAGS_VEC = $(EXR_CFLAGS)

$(BUILD)/librayd.a: $(CORE_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(BUILD)/rayd-render: $(BUILD)/cli/rayd-render.o $(BUILD)/librayd.a
	$(CC) $(LDFLAGS_ALL) -o $@ $^ $(LIBS_CORE)

# --- server -----------------------------------------------------------------
# The preview's static files are compiled into the binary (web_assets.h),
# with examples.js: the scenes/ examples as JS strings for its menu.
WEB_EXAMPLES := $(BUILD)/server/web/examples.js
SCENE_FILES := $(sort $(wildcard scenes/*.json))

$(WEB_EXAMPLES): $(SCENE_FILES) Makefile | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	@{ echo "// generated by make from scenes/*.json: do not edit"; \
	   echo "export const examples = ["; \
	   for f in $(SCENE_FILES); do \
	     printf '  {name: "%s", text: "' "$$(basename $$f .json)"; \
	     sed -e 's/\\/\\\\/g' -e 's/"/\\"/g' -e 's/\r/\\r/g' -e 's/\t/\\t/g' -e 's/$$/\\n/' $$f | tr -d '\n'; \
	     echo '"},'; \
	   done; \
	   echo "];"; } >$@.tmp && mv $@.tmp $@

$(BUILD)/server/web_assets.h: $(WEB_FILES) $(WEB_EXAMPLES) tools/embed.sh | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	sh tools/embed.sh $@ $(WEB_FILES) $(WEB_EXAMPLES)

$(SERVER_OBJ): $(BUILD)/server/web_assets.h

$(BUILD)/rayd: $(SERVER_OBJ) $(BUILD)/librayd.a
	$(CC) $(LDFLAGS_ALL) -o $@ $^ -lmicrohttpd -lcrypto $(LIBS_CORE)

# --- clients ----------------------------------------------------------------
$(BUILD)/rayd-client: $(CLIENT_SRC:%.c=$(BUILD)/%.o) $(BUILD)/librayd.a
	$(CC) $(LDFLAGS_ALL) -o $@ $^ -lcurl -lcrypto $(LIBS_CORE)

# --- tests ------------------------------------------------------------------
# Unit tests may include the core's private headers.
$(BUILD)/tests/%: tests/unit/%.c $(wildcard tests/unit/*.h) $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude -Icore -Itests/unit $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)

# Small programs the shell tests use (not tests themselves).
$(BUILD)/tests/tools/%: tests/tools/%.c $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude -Icore $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)

# The tests' third-party reader of EXR files (OpenEXR's C++ library), not
# built with the sanitizers: it checks rayd's output, it is not rayd.
$(BUILD)/tests/tools/%: tests/tools/%.cc | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CXX) -std=c++17 -O2 -Wall -Wextra -Werror $(EXR_CFLAGS) $< -o $@ $(EXR_LIBS) -lpng

TEST_TOOLS := $(patsubst tests/tools/%.c,$(BUILD)/tests/tools/%,$(wildcard tests/tools/*.c)) \
              $(patsubst tests/tools/%.cc,$(BUILD)/tests/tools/%,$(wildcard tests/tools/*.cc))

# The browser tests drive Debian's chromium with playwright-core from npm,
# installed into tests/browser/node_modules when its lock file changes.  No
# npm (or no registry) is not fatal here: tests/browser/preview.sh then FAILs.
BROWSER_NODE := tests/browser/node_modules/.package-lock.json

$(BROWSER_NODE): tests/browser/package.json tests/browser/package-lock.json
	@if command -v npm >/dev/null 2>&1; then \
	  (cd tests/browser && npm ci --no-audit --no-fund --loglevel=error) || \
	  echo "npm ci in tests/browser failed: the browser tests will fail"; \
	else echo "npm not found: the browser tests will fail (install Node.js and npm)"; fi

test: all $(UNIT_BIN) $(TEST_TOOLS) $(FUZZ_REPLAY) $(BUILD)/bench/genmesh $(BROWSER_NODE)
	@bash tests/run.sh $(BUILD)

# The integration tests with every core busy, pinned to one core, and twice
# idle (tests/stress.sh): none may depend on how long a render takes.
test-stress: all $(TEST_TOOLS) $(FUZZ_REPLAY) $(BUILD)/bench/genmesh $(BROWSER_NODE)
	@bash tests/stress.sh $(BUILD)

# The layers of docs/architecture.md, read from the includes and from the
# objects' symbols (nm): a use of a higher layer or a circle fails.
check-layers: all
	@python3 tools/check_layers.py $(BUILD) && python3 tools/check_layers.py --self-test

test-unit: all $(UNIT_BIN)
	@RAYD_ONLY=unit bash tests/run.sh $(BUILD)

# Rewrites tests/golden/ from tests/scenes/ (after an intended change only).
golden: $(BUILD)/rayd-render
	@for f in tests/scenes/*.json; do n=$$(basename $$f .json); \
	  $(BUILD)/rayd-render $$f -o tests/golden/$$n.png && echo "tests/golden/$$n.png"; done

# --- fuzzing ----------------------------------------------------------------
# Each tests/fuzz/fuzz_X.c is a libFuzzer target.  `make fuzz` builds them
# with clang (fuzzer + ASan + UBSan) into build/fuzz/ and runs each for
# FUZZ_SECONDS on a working copy of its seed corpus tests/fuzz/corpus/X;
# a crash stops with the input saved in build/fuzz/ -- copy it into
# tests/fuzz/regressions/X/ so `make test` replays it forever after.
FUZZ_SECONDS ?= 30
FUZZ_CFLAGS := -std=c11 -D_POSIX_C_SOURCE=200809L -ffp-contract=off -O1 -g -fsanitize=fuzzer-no-link,address,undefined \
               -fno-sanitize-recover=undefined -Iinclude -Icore
FUZZ_CORE_OBJ := $(CORE_SRC:core/%.c=build/fuzz/core/%.o)
.SECONDARY: $(FUZZ_CORE_OBJ)

build/fuzz/core/%.o: core/%.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	clang $(FUZZ_CFLAGS) -MMD -MP -c $< -o $@

build/fuzz/core/io/exr.o: FUZZ_CFLAGS += $(EXR_CFLAGS)

build/fuzz/fuzz_%: tests/fuzz/fuzz_%.c $(FUZZ_CORE_OBJ)
	clang $(FUZZ_CFLAGS) -fsanitize=fuzzer $^ -o $@ $(LIBS_CORE)

# The server's targets (fuzz_http*, fuzz_query*) drive the request flow and
# the handlers without sockets: they link the server's objects but main.o,
# built the same way, and libmicrohttpd (responses) and libcrypto (ids).
FUZZ_SERVER_TARGETS := $(filter http% query%,$(FUZZ_TARGETS))
FUZZ_SERVER_OBJ := $(patsubst server/%.c,build/fuzz/server/%.o,$(filter-out server/main.c,$(SERVER_SRC)))
.SECONDARY: $(FUZZ_SERVER_OBJ)

build/fuzz/server/%.o: server/%.c $(SERVER_HDR) build/server/web_assets.h | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	clang $(FUZZ_CFLAGS) -MMD -MP -D_DEFAULT_SOURCE -Ibuild/server -c $< -o $@

$(FUZZ_SERVER_TARGETS:%=build/fuzz/fuzz_%): build/fuzz/fuzz_%: tests/fuzz/fuzz_%.c \
    tests/fuzz/fuzz_http_common.h $(SERVER_HDR) $(FUZZ_SERVER_OBJ) $(FUZZ_CORE_OBJ)
	clang $(FUZZ_CFLAGS) -D_DEFAULT_SOURCE -fsanitize=fuzzer $(filter %.c %.o,$^) -o $@ \
	  -lmicrohttpd -lcrypto $(LIBS_CORE)

# A crash, leak, timeout or out-of-memory fails the run (the artifact stays
# in build/fuzz/crash-TARGET-*).  Object files track their headers (-MMD).
fuzz: $(FUZZ_TARGETS:%=build/fuzz/fuzz_%)
	@for t in $(FUZZ_TARGETS); do \
	  rm -rf build/fuzz/corpus-$$t build/fuzz/crash-$$t-* && mkdir -p build/fuzz/corpus-$$t && \
	  cp tests/fuzz/corpus/$$t/* build/fuzz/corpus-$$t/ && \
	  echo "== fuzz_$$t for $(FUZZ_SECONDS) s" && \
	  { build/fuzz/fuzz_$$t -max_total_time=$(FUZZ_SECONDS) -max_len=65536 -rss_limit_mb=2048 -timeout=30 \
	    $$( [ -f tests/fuzz/$$t.dict ] && echo -dict=tests/fuzz/$$t.dict ) \
	    -artifact_prefix=build/fuzz/crash-$$t- -print_final_stats=1 build/fuzz/corpus-$$t 2>&1; \
	    echo "exit status $$?"; } | \
	    grep -E "^(stat::number_of_executed_units|stat::peak_rss_mb|==.*ERROR|SUMMARY|exit status)|Done [0-9]+ runs"; \
	  if ls build/fuzz/crash-$$t-* >/dev/null 2>&1; then \
	    echo "fuzz_$$t FAILED: $$(ls build/fuzz/crash-$$t-*) (add it to tests/fuzz/regressions/$$t/ once fixed)"; \
	    exit 1; fi; \
	done

# The same targets without libFuzzer, replaying corpus and regressions.
$(BUILD)/tests/fuzz/replay_%: tests/fuzz/fuzz_%.c tests/fuzz/replay.c $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude -Icore $(filter %.c,$^) -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)

SERVER_LIB_OBJ := $(filter-out $(BUILD)/server/main.o,$(SERVER_OBJ))
$(FUZZ_SERVER_TARGETS:%=$(BUILD)/tests/fuzz/replay_%): $(BUILD)/tests/fuzz/replay_%: \
    tests/fuzz/fuzz_%.c tests/fuzz/replay.c tests/fuzz/fuzz_http_common.h $(SERVER_HDR) \
    $(SERVER_LIB_OBJ) $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -D_DEFAULT_SOURCE -Iinclude -I$(BUILD)/server $(filter %.c,$^) -o $@ \
	  $(LDFLAGS_ALL) $(SERVER_LIB_OBJ) $(BUILD)/librayd.a -lmicrohttpd -lcrypto $(LIBS_CORE)

# --- TSan and valgrind ------------------------------------------------------
# `make test-tsan`: the server built with ThreadSanitizer into build/tsan/,
# the job-queue and server integration tests against it (a TSan report in
# rayd's stderr fails the script that started it).  `make test-valgrind`:
# three integration scripts with rayd under valgrind memcheck (exit 99 on any
# error or definite leak).  Both print "N passed, N failed".
TSAN_TESTS := jobs lifecycle api_basic api_hdr load slow_clients faults api_progressive deadline
VALGRIND_TESTS := security api_errors bad_requests

test-tsan:
	@$(MAKE) --no-print-directory TSAN=1 build/tsan/rayd build/tsan/rayd-render build/tsan/bench/genmesh \
	  build/tsan/tests/tools/hdrcheck
	@TSAN_OPTIONS="halt_on_error=0 second_deadlock_stack=1 $${TSAN_OPTIONS:-}" \
	  RAYD_TIMEOUT=1800 RAYD_TESTS="$(TSAN_TESTS)" bash tests/run.sh build/tsan

test-valgrind: all
	@RAYD_WRAP="valgrind -q --error-exitcode=99 --leak-check=full --errors-for-leak-kinds=definite \
	  --show-leak-kinds=definite" RAYD_START_TRIES=600 \
	  RAYD_TIMEOUT=1800 RAYD_TESTS="$(VALGRIND_TESTS)" bash tests/run.sh build


# --- run, bench, tooling ----------------------------------------------------
run: all
	$(BUILD)/rayd --bind 127.0.0.1 --port 8080

# Benchmark programs: raybench links the core's internals, like unit tests.
# Bench-only Debian packages (Embree and POV-Ray for `make bench-peers`):
# never runtime dependencies, never installed by `make deps`.
BENCH_PKGS := libembree-dev povray
BENCH_DIR := $(BUILD)/bench
# genmesh levels: 20 * 4^L triangles, 5,120 (L=4) .. 1,310,720 (L=8).
BENCH_LEVELS := 4 5 6 7 8
BENCH_SCENES := $(BENCH_LEVELS:%=$(BENCH_DIR)/mesh-%.json)

$(BUILD)/bench/raybench: bench/raybench.c $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude -Icore $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)

$(BUILD)/bench/genmesh: bench/genmesh.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) $< -o $@ $(LDFLAGS_ALL) -lm

# Deterministic meshes (same level, same bytes) and a scene framing each.
$(BENCH_DIR)/mesh-%.ply: $(BUILD)/bench/genmesh
	$< $* $@

$(BENCH_DIR)/mesh-%.json: $(BENCH_DIR)/mesh-%.ply bench/mkscene.py
	python3 bench/mkscene.py $< $@

# The same meshes as OBJ files, and scenes that load them (bench/scenes.sh
# times the whole path of both formats).
$(BENCH_DIR)/mesh-%.obj $(BENCH_DIR)/mesh-%-obj.json: $(BENCH_DIR)/mesh-%.ply $(BENCH_DIR)/mesh-%.json bench/ply2obj.py
	python3 bench/ply2obj.py $< $(BENCH_DIR)/mesh-$*.obj $(BENCH_DIR)/mesh-$*.json $(BENCH_DIR)/mesh-$*-obj.json

$(BUILD)/bench/pngbench: bench/pngbench.c $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)

$(BUILD)/bench/hdrbench: bench/hdrbench.c $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)

.PRECIOUS: $(BENCH_DIR)/mesh-%.ply $(BENCH_DIR)/mesh-%.json $(BENCH_DIR)/mesh-%.obj $(BENCH_DIR)/mesh-%-obj.json

# The Embree side of bench-peers: reuses the core's PLY reader (mesh_io.h).
$(BUILD)/bench/embree_bench: bench/peers/embree_bench.c $(BUILD)/librayd.a | bench-deps
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude -Icore $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a -lembree3 $(LIBS_CORE)

$(BUILD)/bench/imgdiff: bench/peers/imgdiff.c $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)

# After `make deps` (never two apt-gets at once under -j).
bench-deps: | $(BUILD)/.deps-ok
	@missing=""; for p in $(BENCH_PKGS); do \
	  dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q '^install ok installed' || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "make bench-deps: installing$$missing"; \
	  $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	fi

bench: all $(BUILD)/bench/raybench $(BUILD)/bench/genmesh $(BUILD)/bench/pngbench $(BUILD)/bench/hdrbench $(BENCH_SCENES) \
       $(BENCH_DIR)/mesh-8-obj.json
	@bash bench/run.sh $(BUILD)

bench-peers: all bench-deps $(BUILD)/bench/raybench $(BUILD)/bench/embree_bench $(BUILD)/bench/imgdiff \
             $(BENCH_SCENES) $(BENCH_DIR)/mesh-8-obj.json
	@bash bench/peers.sh $(BUILD)

format:
	clang-format -i $(shell git ls-files '*.c' '*.h')

lint:
	cppcheck --quiet --error-exitcode=1 --enable=warning,performance,portability \
	  --inline-suppr -Iinclude -Icore --std=c11 core cli server clients
	clang-tidy --quiet $(CORE_SRC) -- -std=c11 -D_POSIX_C_SOURCE=200809L -Iinclude -Icore

clean:
	rm -rf build

-include $(shell find build -name '*.d' 2>/dev/null)
