# rayd -- build, test, bench, deps, run.
#
#   make             build/librayd.a, build/rayd-render, build/rayd, build/rayd-client
#   make test        every test; ends with "N passed, N failed"
#   make test SANITIZE=1   the same suite built with ASan+UBSan into build/asan/
#   make test-tsan   server + job queue integration tests under ThreadSanitizer (build/tsan/)
#   make test-valgrind  three server integration tests with rayd under valgrind memcheck
#   make test-stress the integration tests loaded, and on one core
#   make run         build and start rayd on 127.0.0.1:8080 with the preview
#   make deps        install the Debian packages the build needs (make does it)
#   make test-deps   and those the tests need as well (make test does it)
#   make shared      build/librayd.so (the core as a shared library)
#   make install     PREFIX=/usr/local DESTDIR=: programs, librayd.a/.so, header,
#                    rayd.pc, man pages, systemd unit;  make uninstall undoes it
#   make bench       benchmarks (never part of make test)
#   make bench-peers the same meshes and sphere scene with Embree and POV-Ray (make bench-deps),
#                    then make bench-pt
#   make bench-pt    the path tracer against Cycles (and Mitsuba 3 with MITSUBA=) at equal quality
#   make bench-cluster the cluster's Redis calls per work item (bench/cluster_queue.sh)
#   make check-layers  includes and calls one way down the layers, no circles
#                    (tools/check_layers.py), docs/architecture.md true to the
#                    tree, no source file over 1000 lines (tools/check_tree.py),
#                    every link between the pages followed (tools/check_links.py;
#                    all part of make test)
#   make format      clang-format every C file (tools/format.sh, the root .clang-format)
#   make format-check  the files that are not clean, listed; fails if any
#   make lint        cppcheck + clang-tidy, every file in parallel (part of .ci/run)
#   make check-exports  no exported function without a caller (tools/unused_exports.py;
#                    part of make test)

# Debian packages, in lists by what needs them (README.md, "Dependencies",
# says what each package is for).  BUILD_PKGS: compilers (g++ for core/codec/exr_imf.cc) and tools, the three
# given libraries (libpng, cJSON, libmicrohttpd), libcurl for the client,
# libssl (libcrypto's SHA-256 of scene ids), libdeflate, libisal and zlib (the PNG
# encoder's deflates), libopenexr-dev (EXR out and environment maps in, core/codec/exr*.c), libstb-dev
# (stb_image: Radiance .hdr environments, core/load/scene_json_env.c), ffmpeg (the
# program rayd-render --video pipes its frames to; ffprobe for the tests).  TEST_PKGS,
# on top for `make test`: curl and python3 (the integration tests), nginx (the
# scale-out test balances through it; installed, never started: tools/deps.sh),
# wrk (the load test), chromium and a font (the preview's browser tests),
# pngcheck, openexr and g++ (readers that check rayd's PNG and EXR files),
# assimp-testmodels (real model files), clang and its runtime (make fuzz),
# valgrind (make test-valgrind), gdb (stops rayd at an unlink for a kill -9 in
# tests/integration/durable_forget.sh), openssl (a certificate for the TLS test),
# man-db (the man pages rendered), python3-prometheus-client (its parser
# reads /metrics in tests/integration/observability.sh).  LINT_PKGS: make lint and make format.
# BENCH_PKGS (below): make bench-peers only.
BUILD_PKGS := gcc g++ make pkg-config libc6-dev libpng-dev zlib1g-dev libisal-dev libdeflate-dev libcjson-dev \
              libmicrohttpd-dev libcurl4-openssl-dev libssl-dev libopenexr-dev libstb-dev ffmpeg \
              libsqlite3-dev libhiredis-dev
TEST_PKGS := curl python3 nginx wrk chromium fonts-dejavu-core pngcheck openexr g++ \
             assimp-testmodels clang libclang-rt-14-dev valgrind gdb openssl man-db \
             python3-prometheus-client redis-server
LINT_PKGS := cppcheck clang-tidy clang-format

# Build on every core unless told otherwise (tests/run.sh runs two tests at a time).
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
# -O3, not -O2: the 1080p sphere frame's one-thread image took 6-8% less CPU
# (raybench --cpu-time, 24 alternating runs) and the whole rayd-render
# process 6% less time, with the same bytes (-ffp-contract=off below keeps
# every rounding); link-time optimisation on top gained under 1%
# (bench/README.md, Nov 29 2026).
OPT := -O3 -g -fno-math-errno
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
# OpenEXR (core/codec/exr.c and exr_read.c only) through pkg-config; recursively expanded, so
# pkg-config runs in recipes, after `make deps` has installed it.
EXR_CFLAGS = $(patsubst -I%,-isystem %,$(shell pkg-config --cflags OpenEXR))
EXR_LIBS = $(shell pkg-config --libs OpenEXR)
# The programs take libpng, libdeflate and stb from the static archives
# Debian's -dev packages ship: three shared libraries fewer to map and
# relocate at each start (rayd-render --version 6.8 -> 5.9 ms, median of 21
# on the 2-core VM, where each page a process first touches costs a fault),
# and libdeflate, the PNG deflate at the default level, 5% faster as an archive
# (the 1080p sphere frame's bands 36.9 -> 35.2 ms of work, median of 9).
# librayd.so links them all as shared libraries (LIBS_SHARED).
# SQLite (server/store.c only, rayd --data-dir) and hiredis (server/cluster/,
# rayd --redis) through pkg-config, as OpenEXR.
STORE_CFLAGS = $(patsubst -I%,-isystem %,$(shell pkg-config --cflags sqlite3 hiredis))
STORE_LIBS = $(shell pkg-config --libs sqlite3 hiredis)
# libstdc++ for core/codec/exr_imf.cc, the core's one C++ file (OpenEXR's C++
# library reads what its C library of Debian 12's release cannot: DWA, tiles).
LIBS_DYN = -lz -lisal -lcjson $(EXR_LIBS) -lstdc++ -lpthread -lm
LIBS_CORE = -Wl,-Bstatic -lpng16 -ldeflate -lstb -Wl,-Bdynamic $(LIBS_DYN)
LIBS_SHARED = -lpng16 -ldeflate -lstb $(LIBS_DYN)

# --- version ----------------------------------------------------------------
# The file VERSION holds the one version string.  Every compile sees it as
# RAYD_VERSION (include/rayd/rayd.h), rayd.pc as its Version, the shared
# library as its file name and, by the major number, its soname.  A new
# VERSION recompiles every object.
VERSION := $(shell cat VERSION)
VERSION_MAJOR := $(firstword $(subst ., ,$(VERSION)))
CFLAGS_ALL += -DRAYD_VERSION='"$(VERSION)"'

CORE_SRC := $(wildcard core/*/*.c)
CORE_CXX_SRC := $(wildcard core/*/*.cc)
CORE_OBJ := $(CORE_SRC:%.c=$(BUILD)/%.o) $(CORE_CXX_SRC:%.cc=$(BUILD)/%.o)
# server/: main.c and one folder per layer (docs/architecture.md).
SERVER_SRC := $(wildcard server/*.c server/*/*.c)
SERVER_OBJ := $(SERVER_SRC:%.c=$(BUILD)/%.o)
SERVER_HDR := $(wildcard server/*.h server/*/*.h)
WEB_FILES := $(wildcard server/web/*)
# The command-line programs (programs/): rayd-render, rayd-client, and the
# room both link, programs/common/ (it uses only include/rayd/rayd.h).
RENDER_SRC := $(wildcard programs/render/*.c)
CLIENT_SRC := $(wildcard programs/client/*.c)
COMMON_SRC := $(wildcard programs/common/*.c)
COMMON_OBJ := $(COMMON_SRC:%.c=$(BUILD)/%.o)
PROGRAMS_OBJ := $(RENDER_SRC:%.c=$(BUILD)/%.o) $(CLIENT_SRC:%.c=$(BUILD)/%.o) $(COMMON_OBJ)
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

.PHONY: all deps test-deps lint-deps shared install uninstall check-layers test test-unit test-stress test-tsan test-valgrind golden readme-images run bench bench-denoise bench-cluster bench-deps bench-peers bench-pt format format-check lint fuzz check-exports clean
.DEFAULT_GOAL := all

all: $(BUILD)/librayd.a $(PROGS)

# --- dependencies ---------------------------------------------------------
# `make deps` installs the build's packages that are missing, `make test-deps`
# the tests' as well (tools/deps.sh: apt-get update once, then only what is
# missing).  Every build checks first through the stamp $(BUILD)/.deps-ok,
# every test target through $(BUILD)/.test-deps-ok; both are redone when the
# Makefile changes.  When a test target is among the goals, the first check
# takes the tests' packages too, so a fresh machine runs apt-get once.
TEST_GOALS := test test-unit test-stress test-tsan test-valgrind test-deps check-layers check-exports fuzz bench \
              bench-cluster
DEPS_PKGS := $(BUILD_PKGS) $(if $(filter $(TEST_GOALS),$(MAKECMDGOALS)),$(TEST_PKGS))

deps:
	@sh tools/deps.sh "make deps" $(BUILD_PKGS)

test-deps: | $(BUILD)/.deps-ok
	@sh tools/deps.sh "make test-deps" $(BUILD_PKGS) $(TEST_PKGS)

$(BUILD)/.deps-ok: Makefile tools/deps.sh
	@sh tools/deps.sh "make deps" $(DEPS_PKGS)
	@mkdir -p $(BUILD) && touch $@

$(BUILD)/.test-deps-ok: Makefile tools/deps.sh | $(BUILD)/.deps-ok
	@sh tools/deps.sh "make test-deps" $(BUILD_PKGS) $(TEST_PKGS)
	@mkdir -p $(BUILD) && touch $@

# --- core -------------------------------------------------------------------
$(BUILD)/%.o: %.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude -c $< -o $@

# server/ and programs/ see only include/: the core's internals stay private.
# A server file names the layer of what it includes ("work/work.h"); the
# programs include their shared room as "common/common.h".
$(BUILD)/server/%.o: server/%.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -D_DEFAULT_SOURCE $(STORE_CFLAGS) -Iserver -Iinclude -I$(BUILD)/server -c $< -o $@

$(BUILD)/programs/%.o: programs/%.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -D_DEFAULT_SOURCE -Iinclude -Iprograms -c $< -o $@

$(BUILD)/core/%.o: core/%.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) $(CFLAGS_VEC) -Iinclude -Icore -c $< -o $@

# The core's C++ (exr_imf.cc): the same optimisation and sanitizers.
CXXFLAGS_ALL = -std=c++17 $(OPT) -Wall -Wextra -Werror -Wshadow -MMD -MP $(EXR_CFLAGS) $(CXXFLAGS)
$(BUILD)/core/%.o: core/%.cc | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CXX) $(CXXFLAGS_ALL) -Iinclude -Icore -c $< -o $@

$(BUILD)/pic/core/%.o: core/%.cc | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CXX) $(CXXFLAGS_ALL) -fPIC -Iinclude -Icore -c $< -o $@

# Loops over a packet's lanes (integrate_wide.c, camera.c) and the PNG row
# filters (png_encode.c) are written for the vectoriser, which -O2 runs only
# on the cheapest loops (-O3 on all, with this cost model): so they stay
# vectorised in a build made with CFLAGS=-O2.  The same for their PIC
# copies (librayd.so).
VEC_OBJ := core/render/integrate_wide.o core/geom/camera.o core/codec/png_encode.o
$(VEC_OBJ:%=$(BUILD)/%) $(VEC_OBJ:%=$(BUILD)/pic/%): CFLAGS_VEC := -ftree-vectorize \
    -fvect-cost-model=dynamic

# The denoiser's tap loop (render/denoise.c) too, and with -fno-trapping-math:
# GCC turns its selects into branches and may not make them selects again
# while a comparison could trap.  It changes no value (no reassociation,
# no contraction): the same bytes with or without it, vectorised or not.
$(BUILD)/core/render/denoise.o $(BUILD)/pic/core/render/denoise.o: CFLAGS_VEC := -ftree-vectorize \
    -fvect-cost-model=dynamic -fno-trapping-math

$(BUILD)/core/codec/exr.o $(BUILD)/pic/core/codec/exr.o $(BUILD)/core/codec/exr_read.o $(BUILD)/pic/core/codec/exr_read.o: CFLAGS_VEC = $(EXR_CFLAGS)

$(BUILD)/librayd.a: $(CORE_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(BUILD)/rayd-render: $(RENDER_SRC:%.c=$(BUILD)/%.o) $(COMMON_OBJ) $(BUILD)/librayd.a
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
	$(CC) $(LDFLAGS_ALL) -o $@ $^ -lmicrohttpd -lcrypto $(STORE_LIBS) $(LIBS_CORE)

# --- clients ----------------------------------------------------------------
$(BUILD)/rayd-client: $(CLIENT_SRC:%.c=$(BUILD)/%.o) $(COMMON_OBJ) $(BUILD)/librayd.a
	$(CC) $(LDFLAGS_ALL) -o $@ $^ -lcurl -lcrypto $(LIBS_CORE)

# --- shared library ---------------------------------------------------------
# librayd.so is the core compiled a second time, as position-independent code,
# into $(BUILD)/pic/ (librayd.a and the programs stay as they are), linked
# with the core's libraries and exporting the rayd_ calls of rayd.h alone
# (packaging/librayd.map).  Its soname carries the major version, its file
# name the whole one; `make shared` builds it, `make install` needs it.
SO_NAME := librayd.so.$(VERSION_MAJOR)
SO_FILE := librayd.so.$(VERSION)
CORE_PIC_OBJ := $(CORE_SRC:%.c=$(BUILD)/pic/%.o) $(CORE_CXX_SRC:%.cc=$(BUILD)/pic/%.o)

$(BUILD)/pic/core/%.o: core/%.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) $(CFLAGS_VEC) -fPIC -Iinclude -Icore -c $< -o $@

$(BUILD)/$(SO_FILE): $(CORE_PIC_OBJ) packaging/librayd.map
	$(CC) -shared -Wl,-soname,$(SO_NAME) -Wl,--version-script=packaging/librayd.map \
	  -Wl,--no-undefined $(LDFLAGS_ALL) -o $@ $(CORE_PIC_OBJ) $(LIBS_SHARED)
	ln -sf $(SO_FILE) $(BUILD)/$(SO_NAME)
	ln -sf $(SO_NAME) $(BUILD)/librayd.so

shared: $(BUILD)/$(SO_FILE)

# Every object sees RAYD_VERSION: a new VERSION compiles them again.
$(CORE_OBJ) $(CORE_PIC_OBJ) $(SERVER_OBJ) $(PROGRAMS_OBJ): VERSION

# --- install ----------------------------------------------------------------
# `make install` copies what `make` and `make shared` build (building first
# what is missing or stale, as they would) under DESTDIR + PREFIX: the
# programs, both libraries with the soname links, the public header (with the
# version written in), rayd.pc, the man pages, the systemd unit and its
# environment file, whose paths follow PREFIX (packaging/).  SYSCONFDIR is
# /etc for PREFIX=/usr, else PREFIX/etc.  An environment file already there
# is kept, as an edited one may be.  `make uninstall` removes the same list,
# and the environment file only when it is still the one shipped.
PREFIX ?= /usr/local
BINDIR ?= $(PREFIX)/bin
LIBDIR ?= $(PREFIX)/lib
INCLUDEDIR ?= $(PREFIX)/include
MANDIR ?= $(PREFIX)/share/man
# The example scenes (and the maps they name), for rayd-render and the man pages' examples.
SCENEDIR ?= $(PREFIX)/share/rayd/scenes
SCENE_SHIPPED := $(sort $(wildcard scenes/*.json scenes/*.hdr))
UNITDIR ?= $(PREFIX)/lib/systemd/system
SYSCONFDIR ?= $(if $(filter /usr,$(PREFIX)),/etc,$(PREFIX)/etc)
MAN_PAGES := $(wildcard docs/man/*.1)
PUBLIC_HEADERS := $(wildcard include/rayd/*.h)
ENV_FILE := $(SYSCONFDIR)/default/rayd
INSTALLED := $(PROGS:$(BUILD)/%=$(BINDIR)/%) \
             $(LIBDIR)/librayd.a $(LIBDIR)/$(SO_FILE) $(LIBDIR)/$(SO_NAME) $(LIBDIR)/librayd.so \
             $(PUBLIC_HEADERS:include/%=$(INCLUDEDIR)/%) $(LIBDIR)/pkgconfig/rayd.pc \
             $(MAN_PAGES:docs/man/%=$(MANDIR)/man1/%) $(UNITDIR)/rayd.service \
             $(SCENE_SHIPPED:scenes/%=$(SCENEDIR)/%)

install: all $(BUILD)/$(SO_FILE)
	install -d $(DESTDIR)$(BINDIR) $(DESTDIR)$(LIBDIR)/pkgconfig $(DESTDIR)$(INCLUDEDIR)/rayd \
	  $(DESTDIR)$(MANDIR)/man1 $(DESTDIR)$(UNITDIR) $(DESTDIR)$(SYSCONFDIR)/default \
	  $(DESTDIR)$(SCENEDIR)
	install -m 755 $(PROGS) $(DESTDIR)$(BINDIR)/
	install -m 644 $(SCENE_SHIPPED) $(DESTDIR)$(SCENEDIR)/
	install -m 644 $(BUILD)/librayd.a $(DESTDIR)$(LIBDIR)/
	install -m 755 $(BUILD)/$(SO_FILE) $(DESTDIR)$(LIBDIR)/
	ln -sf $(SO_FILE) $(DESTDIR)$(LIBDIR)/$(SO_NAME)
	ln -sf $(SO_NAME) $(DESTDIR)$(LIBDIR)/librayd.so
	for h in $(PUBLIC_HEADERS); do \
	  sed 's/^#define RAYD_VERSION "unknown"$$/#define RAYD_VERSION "$(VERSION)"/' $$h \
	    >$(DESTDIR)$(INCLUDEDIR)/rayd/$${h##*/} && \
	  chmod 644 $(DESTDIR)$(INCLUDEDIR)/rayd/$${h##*/} || exit 1; \
	done
	sed -e 's|@PREFIX@|$(PREFIX)|' -e 's|@LIBDIR@|$(LIBDIR)|' -e 's|@INCLUDEDIR@|$(INCLUDEDIR)|' \
	  -e 's|@VERSION@|$(VERSION)|' packaging/rayd.pc.in >$(DESTDIR)$(LIBDIR)/pkgconfig/rayd.pc
	install -m 644 $(MAN_PAGES) $(DESTDIR)$(MANDIR)/man1/
	sed -e 's|/usr/local/bin/|$(BINDIR)/|' -e 's|/usr/local/etc/|$(SYSCONFDIR)/|' \
	  packaging/rayd.service >$(DESTDIR)$(UNITDIR)/rayd.service
	@if [ -e $(DESTDIR)$(ENV_FILE) ] && ! cmp -s packaging/rayd.default $(DESTDIR)$(ENV_FILE); then \
	  echo "make install: $(DESTDIR)$(ENV_FILE) kept (the shipped one: packaging/rayd.default)"; \
	else install -m 644 packaging/rayd.default $(DESTDIR)$(ENV_FILE); fi
	@if [ -z "$(DESTDIR)" ] && [ "$$(id -u)" = 0 ]; then ldconfig; fi

uninstall:
	rm -f $(addprefix $(DESTDIR),$(INSTALLED))
	@if cmp -s packaging/rayd.default $(DESTDIR)$(ENV_FILE); then rm -f $(DESTDIR)$(ENV_FILE); \
	elif [ -e $(DESTDIR)$(ENV_FILE) ]; then \
	  echo "make uninstall: $(DESTDIR)$(ENV_FILE) was edited: kept"; fi
	@rmdir $(DESTDIR)$(INCLUDEDIR)/rayd 2>/dev/null || true
	@rmdir $(DESTDIR)$(SCENEDIR) $(dir $(DESTDIR)$(SCENEDIR)) 2>/dev/null || true

# --- tests ------------------------------------------------------------------
# Unit tests may include the core's private headers.
$(BUILD)/tests/%: tests/unit/%.c $(wildcard tests/unit/*.h) $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) $(TEST_CFLAGS) -Iinclude -Icore -Itests/unit $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)
# test_aov and test_hdr read their EXRs back through OpenEXR's own reader.
$(BUILD)/tests/test_aov $(BUILD)/tests/test_hdr: TEST_CFLAGS = $(EXR_CFLAGS)

# Small programs the shell tests use (not tests themselves).
$(BUILD)/tests/tools/%: tests/tools/%.c $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude -Icore $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)

# The tests' third-party reader of EXR files (OpenEXR's C++ library), not
# built with the sanitizers: it checks rayd's output, it is not rayd.
$(BUILD)/tests/tools/%: tests/tools/%.cc | $(BUILD)/.test-deps-ok
	@mkdir -p $(dir $@)
	$(CXX) -std=c++17 -O2 -Wall -Wextra -Werror $(EXR_CFLAGS) $< -o $@ $(EXR_LIBS) -lpng

TEST_TOOLS := $(patsubst tests/tools/%.c,$(BUILD)/tests/tools/%,$(wildcard tests/tools/*.c)) \
              $(patsubst tests/tools/%.cc,$(BUILD)/tests/tools/%,$(wildcard tests/tools/*.cc))

# The browser tests drive Debian's chromium with playwright-core from npm,
# installed into tests/browser/node_modules when its lock file changes.  No
# npm (or no registry) is not fatal here: tests/browser/preview.sh then FAILs.
BROWSER_NODE := tests/browser/node_modules/.package-lock.json

# npm_ci DIR,CONSEQUENCE: DIR's lock file installed into DIR/node_modules;
# without npm (or the registry) the recipe says what follows, never fails.
define npm_ci
	@if command -v npm >/dev/null 2>&1; then \
	  (cd $(1) && npm ci --no-audit --no-fund --loglevel=error) || \
	  echo "npm ci in $(1) failed: $(2)"; \
	else echo "npm not found: $(2) (install Node.js and npm)"; fi
endef

$(BROWSER_NODE): tests/browser/package.json tests/browser/package-lock.json
	$(call npm_ci,tests/browser,the browser tests will fail)

# docker/k8s/ is validated offline with kubernetes-models (the Kubernetes and
# prometheus-operator schemas) from npm, installed into tests/k8s/node_modules
# the same way; without it tests/integration/k8s_manifests.sh says SKIP.
K8S_NODE := tests/k8s/node_modules/.package-lock.json

$(K8S_NODE): tests/k8s/package.json tests/k8s/package-lock.json
	$(call npm_ci,tests/k8s,the manifest test will SKIP)

test: all $(UNIT_BIN) $(TEST_TOOLS) $(FUZZ_REPLAY) $(BUILD)/bench/genmesh $(BROWSER_NODE) $(K8S_NODE) \
      $(BUILD)/$(SO_FILE) \
      | $(BUILD)/.test-deps-ok
	@bash tests/run.sh $(BUILD)

# The integration tests with every core busy and pinned to one core
# (tests/stress.sh): none may depend on how long a render takes.
test-stress: all $(TEST_TOOLS) $(FUZZ_REPLAY) $(BUILD)/bench/genmesh $(BROWSER_NODE) \
             $(BUILD)/$(SO_FILE) \
             | $(BUILD)/.test-deps-ok
	@bash tests/stress.sh $(BUILD)

# The layers of docs/architecture.md, read from the includes and from the
# objects' symbols (nm): a use of a higher layer or a circle fails; the
# page itself checked against the tree (tools/check_tree.py); and every
# link between the pages followed (tools/check_links.py).
check-layers: all | $(BUILD)/.test-deps-ok
	@python3 tools/check_layers.py $(BUILD) && python3 tools/check_layers.py --self-test && \
	  python3 tools/check_tree.py && python3 tools/check_tree.py --self-test && \
	  python3 tools/check_links.py && python3 tools/check_links.py --self-test

test-unit: all $(UNIT_BIN) | $(BUILD)/.test-deps-ok
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
FUZZ_CFLAGS += -DRAYD_VERSION='"$(VERSION)"'
FUZZ_CORE_OBJ := $(CORE_SRC:core/%.c=build/fuzz/core/%.o) $(CORE_CXX_SRC:core/%.cc=build/fuzz/core/%.o)
.SECONDARY: $(FUZZ_CORE_OBJ)

build/fuzz/core/%.o: core/%.c | $(BUILD)/.test-deps-ok
	@mkdir -p $(dir $@)
	clang $(FUZZ_CFLAGS) -MMD -MP -c $< -o $@

build/fuzz/core/codec/exr.o build/fuzz/core/codec/exr_read.o: FUZZ_CFLAGS += $(EXR_CFLAGS)

build/fuzz/core/%.o: core/%.cc | $(BUILD)/.test-deps-ok
	@mkdir -p $(dir $@)
	clang++ -std=c++17 -O1 -g -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize=vptr \
	  -Iinclude -Icore $(EXR_CFLAGS) -MMD -MP -c $< -o $@

build/fuzz/fuzz_%: tests/fuzz/fuzz_%.c $(FUZZ_CORE_OBJ)
	clang $(FUZZ_CFLAGS) -fsanitize=fuzzer $^ -o $@ $(LIBS_CORE)

# The server's targets (fuzz_http*, fuzz_query*) drive the request flow and
# the handlers without sockets: they link the server's objects but main.o,
# built the same way, and libmicrohttpd (responses) and libcrypto (ids).
FUZZ_SERVER_TARGETS := $(filter http% query%,$(FUZZ_TARGETS))
FUZZ_SERVER_OBJ := $(patsubst server/%.c,build/fuzz/server/%.o,$(filter-out server/main.c,$(SERVER_SRC)))
.SECONDARY: $(FUZZ_SERVER_OBJ)

build/fuzz/server/%.o: server/%.c $(SERVER_HDR) build/server/web_assets.h | $(BUILD)/.test-deps-ok
	@mkdir -p $(dir $@)
	clang -Iserver $(FUZZ_CFLAGS) -MMD -MP -D_DEFAULT_SOURCE $(STORE_CFLAGS) -Ibuild/server -c $< -o $@

$(FUZZ_SERVER_TARGETS:%=build/fuzz/fuzz_%): build/fuzz/fuzz_%: tests/fuzz/fuzz_%.c \
    tests/fuzz/fuzz_http_common.h $(SERVER_HDR) $(FUZZ_SERVER_OBJ) $(FUZZ_CORE_OBJ)
	clang -Iserver $(FUZZ_CFLAGS) -D_DEFAULT_SOURCE -fsanitize=fuzzer $(filter %.c %.o,$^) -o $@ \
	  -lmicrohttpd -lcrypto $(STORE_LIBS) $(LIBS_CORE)

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
	$(CC) $(CFLAGS_ALL) -D_DEFAULT_SOURCE -Iserver -Iinclude -I$(BUILD)/server $(filter %.c,$^) -o $@ \
	  $(LDFLAGS_ALL) $(SERVER_LIB_OBJ) $(BUILD)/librayd.a -lmicrohttpd -lcrypto $(STORE_LIBS) $(LIBS_CORE)

# --- TSan and valgrind ------------------------------------------------------
# `make test-tsan`: the server built with ThreadSanitizer into build/tsan/,
# the job-queue and server integration tests against it (a TSan report in
# rayd's stderr fails the script that started it).  `make test-valgrind`:
# three integration scripts with rayd under valgrind memcheck (exit 99 on any
# error or definite leak).  Both print "N passed, N failed".
TSAN_TESTS := jobs lifecycle api_basic api_hdr load slow_clients slow_headers faults api_progressive deadline fair observability offload limits_runtime memory_budget \
              jobs_frames jobs_frames_durable frames_textures frames_meshes cluster cluster_faults cluster_items cluster_limits cluster_passes
# the render's threads and the PNG stream sharing a window image's rows
TSAN_UNIT := test_png_stream
VALGRIND_TESTS := security api_errors bad_requests

test-tsan: | $(BUILD)/.test-deps-ok
	@$(MAKE) --no-print-directory TSAN=1 build/tsan/rayd build/tsan/rayd-render build/tsan/rayd-client \
	  build/tsan/bench/genmesh build/tsan/tests/tools/hdrcheck $(TSAN_UNIT:%=build/tsan/tests/%)
	@TSAN_OPTIONS="halt_on_error=0 second_deadlock_stack=1 $${TSAN_OPTIONS:-}" \
	  RAYD_TIMEOUT=1800 RAYD_TESTS="$(TSAN_TESTS)" RAYD_UNIT="$(TSAN_UNIT)" bash tests/run.sh build/tsan

test-valgrind: all | $(BUILD)/.test-deps-ok
	@RAYD_WRAP="valgrind -q --error-exitcode=99 --leak-check=full --errors-for-leak-kinds=definite \
	  --show-leak-kinds=definite" RAYD_START_TRIES=600 \
	  RAYD_TIMEOUT=1800 RAYD_TESTS="$(VALGRIND_TESTS)" bash tests/run.sh build


# --- run, bench, tooling ----------------------------------------------------
# Rewrites docs/images/model.png and model-turntable.png, the README's
# pictures of a real model (needs assimp-testmodels).
readme-images: $(BUILD)/rayd-render | $(BUILD)/.test-deps-ok
	bash tools/readme_images.sh $(BUILD)

# make run PORT=9090 BIND=0.0.0.0 THREADS=4 DATA=DIR: where it listens, how
# many workers (default: one per core), where its jobs are kept (one rayd a
# folder: another port keeps its own, build/data-PORT, so a second make run
# beside the first needs only PORT); rayd names a bad value itself.
PORT ?= 8080
BIND ?= 127.0.0.1
THREADS ?=
DATA ?= $(BUILD)/data$(if $(filter-out 8080,$(PORT)),-$(PORT))
run: all
	$(BUILD)/rayd --bind $(BIND) --port $(PORT) $(if $(THREADS),--threads $(THREADS)) \
	  --data-dir $(DATA)

# Benchmark programs: raybench links the core's internals, like unit tests.
# Bench-only Debian packages (Embree and POV-Ray for `make bench-peers`,
# tinyobjloader and g++ for the Embree side's OBJ parse, bench/peers/objparse.cc,
# Blender for its Cycles path tracer in `make bench-pt`):
# never runtime dependencies, never installed by `make deps`.
BENCH_PKGS := libembree-dev povray libtinyobjloader-dev g++ blender
BENCH_DIR := $(BUILD)/bench
# genmesh levels: 20 * 4^L triangles, 5,120 (L=4) .. 1,310,720 (L=8).
BENCH_LEVELS := 4 5 6 7 8
BENCH_SCENES := $(BENCH_LEVELS:%=$(BENCH_DIR)/mesh-%.json)

$(BUILD)/bench/raybench: bench/raybench.c bench/bounce.h tests/unit/peak_rss.h $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude -Icore $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)

$(BUILD)/bench/genmesh: bench/genmesh.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) $< -o $@ $(LDFLAGS_ALL) -lm

# The benches' timer of a whole process (fork to exit).
$(BUILD)/bench/walltime: bench/walltime.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) $< -o $@ $(LDFLAGS_ALL)

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

# The environment map's sampling against BSDF sampling alone (its switch is internal).
$(BUILD)/bench/envbench: bench/envbench.c $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude -Icore $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)

# The denoiser against a reference and two baselines (bench/denoise.sh).
$(BUILD)/bench/denoise: bench/denoise.c $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude -Icore $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)

bench-denoise: all $(BUILD)/bench/denoise | $(BUILD)/.test-deps-ok
	@bash bench/denoise.sh $(BUILD)

# The cluster's Redis calls per work item, and results in Redis against files
# on a volume (bench/cluster_queue.sh starts its own redis-server).
$(BUILD)/bench/cluster_queue: bench/cluster_queue.c | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) $(patsubst -I%,-isystem %,$(shell pkg-config --cflags hiredis)) $< -o $@ \
	    $(LDFLAGS_ALL) $(shell pkg-config --libs hiredis) -pthread

bench-cluster: $(BUILD)/bench/cluster_queue | $(BUILD)/.test-deps-ok
	@bash bench/cluster_queue.sh $(BUILD)

.PRECIOUS: $(BENCH_DIR)/mesh-%.ply $(BENCH_DIR)/mesh-%.json $(BENCH_DIR)/mesh-%.obj $(BENCH_DIR)/mesh-%-obj.json

# The Embree side of bench-peers: reuses the core's PLY reader (mesh_io.h).
$(BUILD)/bench/embree_bench: bench/peers/embree_bench.c bench/bounce.h $(BUILD)/librayd.a | bench-deps
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude -Icore $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a -lembree3 $(LIBS_CORE)

$(BUILD)/bench/objparse: bench/peers/objparse.cc | bench-deps
	@mkdir -p $(dir $@)
	$(CXX) -std=c++17 -O2 -Wall -Wextra -Werror $< -o $@ -ltinyobjloader

$(BUILD)/bench/imgdiff: bench/peers/imgdiff.c $(BUILD)/librayd.a
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_ALL) -Iinclude $< -o $@ $(LDFLAGS_ALL) $(BUILD)/librayd.a $(LIBS_CORE)

# bench-pt's reader of both renderers' EXRs (OpenEXR's C++ library, as
# libopenexr-dev in BUILD_PKGS has it).
$(BUILD)/bench/exrraw: bench/peers/exrraw.cc | $(BUILD)/.deps-ok
	@mkdir -p $(dir $@)
	$(CXX) -std=c++17 -O2 -Wall -Wextra -Werror $$(pkg-config --cflags OpenEXR) $< -o $@ \
	    $$(pkg-config --libs OpenEXR)

# After `make deps` (never two apt-gets at once under -j).
bench-deps: | $(BUILD)/.deps-ok
	@sh tools/deps.sh "make bench-deps" $(BENCH_PKGS)

bench: all $(BUILD)/bench/raybench $(BUILD)/bench/genmesh $(BUILD)/bench/pngbench $(BUILD)/bench/hdrbench $(BENCH_SCENES) \
       $(BENCH_DIR)/mesh-8-obj.json $(BUILD)/bench/walltime | $(BUILD)/.test-deps-ok
	@bash bench/run.sh $(BUILD)

bench-peers: all bench-deps $(BUILD)/bench/raybench $(BUILD)/bench/embree_bench $(BUILD)/bench/imgdiff \
             $(BENCH_SCENES) $(BENCH_DIR)/mesh-8-obj.json $(BUILD)/bench/walltime $(BUILD)/bench/objparse \
             $(BUILD)/bench/exrraw
	@bash bench/peers.sh $(BUILD)
	@bash bench/bunny.sh $(BUILD) && python3 bench/pt.py $(BUILD)

# The path tracer against Cycles (and Mitsuba 3: MITSUBA=, MITSUBA_VARIANT=) at equal quality
# (bench/pt.py).  No bench-deps prerequisite: without blender it stops, saying to run it.
bench-pt: all $(BUILD)/bench/walltime $(BUILD)/bench/exrraw
	@bash bench/bunny.sh $(BUILD) && python3 bench/pt.py $(BUILD)

lint-deps:
	@sh tools/deps.sh "make lint" $(LINT_PKGS)

# Every .c and .h git knows, found by pattern (tools/format.sh): moved or new
# folders are covered without a list here.
format: lint-deps
	@sh tools/format.sh

format-check: lint-deps
	@sh tools/format.sh --check

check-exports: all | $(BUILD)/.test-deps-ok
	@python3 tools/unused_exports.py $(BUILD) && python3 tools/unused_exports.py --self-test

# clang-tidy sees each file with its compile's flags (the rules above); the
# server's include the generated web_assets.h.  One process per file (clang-tidy
# 14, given several files in one process, reports va_lists as uninitialised
# that va_start has set), LINT_JOBS at a time, every program's files in one
# queue so no core waits for a slow file of another group; cppcheck runs
# beside them.  The checks are .clang-tidy's.
LINT_JOBS ?= $(shell nproc 2>/dev/null || echo 2)
LINT_STD := -std=c11 -D_POSIX_C_SOURCE=200809L -DRAYD_VERSION="$(VERSION)"
LINT_CORE_FLAGS = $(LINT_STD) -Iinclude -Icore $(EXR_CFLAGS)
LINT_SERVER_FLAGS := $(LINT_STD) -D_DEFAULT_SOURCE -Iserver -Iinclude -I$(BUILD)/server
LINT_PROG_FLAGS := $(LINT_STD) -D_DEFAULT_SOURCE -Iinclude -Iprograms
PROG_SRC = $(RENDER_SRC) $(CLIENT_SRC) $(COMMON_SRC)

lint: lint-deps $(BUILD)/server/web_assets.h
	@start=$$(date +%s); \
	cppcheck --quiet --error-exitcode=1 --enable=warning,performance,portability \
	  --inline-suppr -Iinclude -Icore -Iserver -Iprograms --std=c11 $(CORE_SRC) $(SERVER_SRC) $(PROG_SRC) & cpp=$$!; \
	{ for f in $(CORE_SRC); do echo "$$f"'|$(LINT_CORE_FLAGS)'; done; \
	  for f in $(SERVER_SRC); do echo "$$f"'|$(LINT_SERVER_FLAGS)'; done; \
	  for f in $(PROG_SRC); do echo "$$f"'|$(LINT_PROG_FLAGS)'; done; } | \
	  xargs -P $(LINT_JOBS) -d '\n' -n 1 sh -c 'f=$${1%%|*}; exec clang-tidy --quiet \
	    --warnings-as-errors="*" "$$f" -- $${1#*|}' lint; tidy=$$?; \
	wait $$cpp; cpp=$$?; \
	echo "lint: cppcheck $$([ $$cpp = 0 ] && echo clean || echo FAILED)," \
	  "clang-tidy $$([ $$tidy = 0 ] && echo clean || echo FAILED), $$(( $$(date +%s) - start )) s"; \
	[ $$cpp = 0 ] && [ $$tidy = 0 ]

clean:
	rm -rf build

-include $(shell find build -name '*.d' 2>/dev/null)
