#!/usr/bin/env bash
# The packet code (AVX-512 where the CPU has it), the AVX2 code, packets of
# 8 rays and the AVX2 one-ray walk (RAYD_NO_AVX512=1, as on a CPU with AVX2
# only) and the build's own one-ray walk (RAYD_NO_AVX2=1, as on a CPU
# without AVX2) give the same PNG bytes: every example scene and the sphere benchmark scene,
# rendered small, and regions of one of them.  Where the CPU lacks a set,
# the runs that would use it take the next and match trivially; the test
# says which sets this CPU has.
set -u
cd "$RAYD_ROOT"
R="$RAYD_BUILD/rayd-render"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
simd=no avx2=no
grep -qw avx512f /proc/cpuinfo 2>/dev/null && simd=yes
grep -qw avx2 /proc/cpuinfo 2>/dev/null && avx2=yes
# a mesh scene too: a displaced subdivided sphere and an instance of it
"$RAYD_BUILD/bench/genmesh" 4 "$T/mesh.ply" || echo "FAIL genmesh: exit $?"
cat >"$T/mesh.json" <<JSON
{"camera": {"position": [0.3, 0.4, 3.2], "look_at": [0, 0, 0], "fov_x": 50},
 "render": {"width": 160, "height": 120},
 "lights": [{"type": "point", "position": [4, 5, 6]}, {"type": "point", "position": [-3, 2, 4]}],
 "objects": [{"type": "plane", "point": [0, -1.2, 0], "material": {"reflectivity": 0.3}},
             {"type": "mesh", "source": {"file": "mesh.ply"}, "smooth": true,
              "material": {"color": [0.8, 0.7, 0.6], "specular": 0.4, "reflectivity": 0.2}},
             {"type": "mesh", "source": {"file": "mesh.ply"},
              "transform": {"scale": 0.5, "translate": [1.2, 0.3, -1]}}]}
JSON
for scene in scenes/*.json bench/scenes/spheres10.json tests/scenes/*.json "$T/mesh.json"; do
    [ -f "$scene" ] || continue
    name=$(dirname "$scene" | tr / -)-$(basename "$scene" .json) # tests/scenes has the same names
    [ "$scene" = "$T/mesh.json" ] && name=genmesh
    # 96 x 54 of the frame: a region keeps the scene's own camera and size
    w=$(awk -F'[:,]' '/"width"/ {for (i = 1; i <= NF; i++) if ($i ~ /"width"/) {print $(i + 1) + 0; exit}}' "$scene")
    args=()
    [ "${w:-0}" -gt 200 ] && args=(--region 0,0,200,120)
    if ! "$R" "$scene" -o "$T/a.png" "${args[@]}" 2>"$T/err" ||
       ! RAYD_NO_AVX512=1 "$R" "$scene" -o "$T/b.png" "${args[@]}" 2>>"$T/err" ||
       ! RAYD_NO_AVX2=1 "$R" "$scene" -o "$T/c.png" "${args[@]}" 2>>"$T/err"; then
        echo "FAIL simd-equals-scalar-$name: $(tail -1 "$T/err")"
        continue
    fi
    if ! cmp -s "$T/a.png" "$T/b.png"; then
        echo "FAIL simd-equals-scalar-$name: the PNG bytes differ without AVX-512"
    elif ! cmp -s "$T/a.png" "$T/c.png"; then
        echo "FAIL simd-equals-scalar-$name: the PNG bytes differ without AVX2"
    else
        echo "PASS simd-equals-scalar-$name (AVX-512 on this CPU: $simd, AVX2: $avx2)"
    fi
done
