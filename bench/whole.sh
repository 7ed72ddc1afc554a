#!/usr/bin/env bash
# bench/whole.sh BUILD -- the whole wait, by stage, where it is not the
# render: the 1.3M-triangle benchmark mesh loaded from binary PLY and from
# OBJ (read, parse + mesh decode + BVH build, render, PNG), then the PNG
# encoder alone against libpng (bench/pngbench.c) on renders of the sphere
# scene and the example scenes.  Medians of RUNS runs (default 3).
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
D=$BUILD/bench
echo "-- the 1.3M-triangle mesh, binary PLY and OBJ, 1920x1080, 2 threads"
SCENES="$D/mesh-8.json $D/mesh-8-obj.json" bash bench/scenes.sh "$BUILD"
echo "-- PNG encoding: rayd's bands against libpng level 6 (one thread)"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$BUILD/rayd-render" bench/scenes/spheres10.json -o "$tmp/spheres10.png" 2>/dev/null
for s in scenes/*.json; do
    "$BUILD/rayd-render" "$s" -o "$tmp/$(basename "$s" .json).png" 2>/dev/null
done
"$D/pngbench" "$tmp"/*.png | sed "s#$tmp/##"
