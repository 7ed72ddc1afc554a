#!/usr/bin/env bash
# bench/gltf.sh BUILD -- how long rayd-render takes to load the same mesh as
# binary PLY and as .glb, and the largest glTF of assimp-testmodels: the
# medians of RUNS runs (default 5) of `rayd-render --stats`' decode (file
# read and decoded) and build (BVH) times, on a 32x24 image so the render
# does not matter.  The 1.3M-triangle mesh is genmesh level 8, turned into a
# .glb with the same vertices and triangles by bench/ply2glb.py.
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
RUNS=${RUNS:-5}
D=$BUILD/bench
mkdir -p "$D"
make -s "$D/genmesh" "$BUILD/rayd-render" >/dev/null
[ -s "$D/mesh-8.ply" ] || "$D/genmesh" 8 "$D/mesh-8.ply"
[ -s "$D/mesh-8.glb" ] || python3 bench/ply2glb.py "$D/mesh-8.ply" "$D/mesh-8.glb"
ENGINE=/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb

median() { sort -n | awk '{v[NR] = $1} END {print v[int((NR + 1) / 2)]}'; }
printf '%-26s %10s %10s %10s\n' file decode_s build_s total_s
for f in "$(pwd)/$D/mesh-8.ply" "$(pwd)/$D/mesh-8.glb" "$ENGINE"; do
    [ -s "$f" ] || continue
    printf '{"render": {"width": 32, "height": 24}, "camera": {"position": [0, 0, 4]},
             "objects": [{"type": "mesh", "source": {"file": "%s"}}]}' "$f" >"$D/gltf-bench.json"
    for i in $(seq "$RUNS"); do
        "$BUILD/rayd-render" "$D/gltf-bench.json" -o "$D/gltf-bench.png" --stats -q 2>&1
    done >"$D/gltf-bench.txt"
    dec=$(awk '$2 == "decode:" {print $3}' "$D/gltf-bench.txt" | median)
    bld=$(awk '$2 == "build:" {print $3}' "$D/gltf-bench.txt" | median)
    tot=$(awk '$2 == "total:" {print $3}' "$D/gltf-bench.txt" | median)
    printf '%-26s %10s %10s %10s\n' "$(basename "$f")" "$dec" "$bld" "$tot"
done
