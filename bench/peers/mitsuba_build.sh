#!/bin/sh
# mitsuba_build.sh SRC BUILD -- builds Mitsuba 3's scalar_rgb variant alone
# (no Python; with Embree where its submodule is there, as Mitsuba's own
# build takes it) for `make bench-pt`'s optional Mitsuba side:
# MITSUBA=BUILD/mitsuba make bench-pt.  VARIANTS=llvm_ad_rgb builds its
# vectorising JIT variant instead ("scalar_rgb,llvm_ad_rgb" both), which
# runs where Dr.Jit finds an LLVM library (Debian's libllvm15 serves):
# MITSUBA=BUILD/mitsuba MITSUBA_VARIANT=llvm_ad_rgb make bench-pt.
#
# SRC is a checkout of Mitsuba 3.8.0 with its submodules:
#   git clone --recursive -b v3.8.0 https://github.com/mitsuba-renderer/mitsuba3 SRC
# (this needs GitHub, so nothing in rayd's own build runs it).  A build
# without Python needs five small changes to 3.8.0, made here in place
# and idempotently:
#   - ext/CMakeLists.txt adds nanothread a second time without JIT;
#   - libmitsuba calls into Dr.Jit's core and its autodiff library even in
#     a scalar build, so it links both whatever the variants;
#   - the HDR film asks the LLVM backend to drop frozen functions on every
#     render, which throws where no JIT variant initialised it: asked only
#     of JIT variants;
#   - nanobind's headers are included (object.h) though Python is off;
#   - without scalar_rgb among the variants, its reconstruction filter,
#     which the bitmap's resampler takes whatever the variants, is
#     instantiated by hand (and the line taken out again with it).
# On 2 cores: about 40 minutes for scalar_rgb without Embree, 25 for
# llvm_ad_rgb without it and 40 with it (Embree's kernels are the rest).
set -eu
SRC=$(cd "$1" && pwd)
BUILD=$2
[ -f "$SRC/ext/drjit/ext/drjit-core/CMakeLists.txt" ] ||
    { echo "mitsuba_build: $SRC has no submodules (git clone --recursive)" >&2; exit 1; }

VARIANTS=${VARIANTS:-scalar_rgb}
python3 - "$SRC" "$VARIANTS" <<'EOF'
import sys
src, variants = sys.argv[1], sys.argv[2].split(",")
def patch(path, old, new):
    path = src + "/" + path
    with open(path) as f:
        s = f.read()
    if new in s:
        return
    if old not in s:
        sys.exit("mitsuba_build: %s is not as 3.8.0 has it" % path)
    with open(path, "w") as f:
        f.write(s.replace(old, new))
patch("ext/CMakeLists.txt", "if (NOT MI_ENABLE_JIT)\n    add_subdirectory(drjit/ext/drjit-core/ext/nanothread)",
      "if (NOT MI_ENABLE_JIT AND NOT TARGET nanothread)\n    add_subdirectory(drjit/ext/drjit-core/ext/nanothread)")
patch("src/core/CMakeLists.txt", "if (MI_ENABLE_JIT)\n  target_link_libraries(mitsuba-core PUBLIC drjit-core)",
      "if (TRUE)\n  target_link_libraries(mitsuba-core PUBLIC drjit-core)")
patch("src/core/CMakeLists.txt", "if (MI_ENABLE_AUTODIFF)\n  target_link_libraries(mitsuba-core PUBLIC drjit-extra)",
      "if (TRUE)\n  target_link_libraries(mitsuba-core PUBLIC drjit-extra)")
patch("src/films/hdrfilm.cpp", "if (m_storage ==  nullptr)\n                jit_freeze_discard",
      "if (dr::is_jit_v<Float> && m_storage ==  nullptr)\n                jit_freeze_discard")
filt = "\ntemplate class MI_EXPORT_LIB mitsuba::ReconstructionFilter<float, mitsuba::Color<float, 3>>;\n"
with open(src + "/src/core/rfilter.cpp") as f:
    s = f.read()
t = s.replace(filt, "") + ("" if "scalar_rgb" in variants else filt)
if t != s:
    with open(src + "/src/core/rfilter.cpp", "w") as f:
        f.write(t)
EOF
# Embree as Mitsuba's own build takes it (its kernels for four vector
# widths) where its submodule is there.
embree=OFF
[ -f "$SRC/ext/embree/CMakeLists.txt" ] && embree=ON
mkdir -p "$SRC/resources/data/ior" "$SRC/resources/data/sunsky/output" "$BUILD"
cmake -S "$SRC" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DMI_ENABLE_PYTHON=OFF \
    -DMI_ENABLE_EMBREE=$embree -DMI_DEFAULT_VARIANTS="$VARIANTS" \
    -DCMAKE_CXX_FLAGS="-I$SRC/ext/nanobind/include"
ninja -C "$BUILD"
echo "mitsuba_build: MITSUBA=$BUILD/mitsuba MITSUBA_VARIANT=${VARIANTS%%,*} make bench-pt"
