#!/usr/bin/env bash
# bench/meshes.sh BUILD -- ray throughput on the benchmark meshes and the
# 10x10-sphere Whitted scene: one table, one row per scene, every figure a
# median of RUNS runs (default 3) from build/bench/raybench at 1920x1080.
#
#   tris      triangles in the scene (0: spheres and a plane only)
#   build s   BVH build of the largest mesh on 2 threads (not the PLY parse)
#   B/tri     bytes of mesh data + BVH per triangle
#   prim 1t/2t   primary rays, Mrays/s: one per pixel centre, nearest hit
#   shad 1t/2t   shadow rays as pixels/s (M): a primary ray per pixel plus an
#                any-hit ray from each hit toward the first light
#   pk 1t/2t, pks 1t/2t  the same two as packets of 4x4 pixels
#                (scene_intersect16, scene_transmittance16)
#   image s   one whole shaded image end to end (rayd_render) on 2 threads
#
# The meshes come from the Makefile (genmesh levels 4..8) and bench/bunny.sh.
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
RUNS=${RUNS:-3}
D=$BUILD/bench
mkdir -p "$D/results"

bash bench/bunny.sh "$BUILD"
scenes=()
for l in 4 5 6 7 8; do scenes+=("$D/mesh-$l.json"); done
[ -s "$D/bunny.json" ] && scenes+=("$D/bunny.json")
scenes+=(bench/scenes/spheres10.json)

kv() { awk -v k="$2" '$1 == k {print $2; f=1} END {if (!f) print "-"}' "$1"; }

printf '%-10s %8s %7s %5s %7s %7s %7s %7s %7s %7s %7s %7s %7s\n' \
    scene tris "build s" "B/tri" "prim 1t" "prim 2t" "shad 1t" "shad 2t" \
    "pk 1t" "pk 2t" "pks 1t" "pks 2t" "image s"
for sc in "${scenes[@]}"; do
    name=$(basename "$sc" .json)
    out=$D/results/$name.raybench
    if ! "$D/raybench" "$sc" --runs "$RUNS" --threads-max 2 >"$out" 2>"$out.err"; then
        printf '%-10s failed: %s\n' "$name" "$(tail -1 "$out.err")"
        continue
    fi
    build=$(kv "$out" bvh_build_s)
    [ "$(kv "$out" triangles)" = 0 ] && build=-
    printf '%-10s %8s %7s %5s %7s %7s %7s %7s %7s %7s %7s %7s %7s\n' "$name" \
        "$(kv "$out" triangles)" "$build" "$(kv "$out" bytes_per_triangle)" \
        "$(kv "$out" primary_mrays_1t)" "$(kv "$out" primary_mrays_2t)" \
        "$(kv "$out" shadow_mrays_1t)" "$(kv "$out" shadow_mrays_2t)" \
        "$(kv "$out" primary_packet_mrays_1t)" "$(kv "$out" primary_packet_mrays_2t)" \
        "$(kv "$out" shadow_packet_mrays_1t)" "$(kv "$out" shadow_packet_mrays_2t)" \
        "$(kv "$out" image_s_2t)"
done
echo "(Mrays/s at 1920x1080, medians of $RUNS runs; raw figures in $D/results/)"
