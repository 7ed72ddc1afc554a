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

# The same frame over HTTP: POST /v1/render of the 1080p sphere scene (a
# new scene each time: a tag in the body, so neither cache answers) against
# the whole rayd-render process, interleaved, medians of RUNS * 3.  The
# request is timed by curl from its connect to the last byte of the reply
# (%{time_total}); curl's own start, 20-30 ms here for its libraries (TLS
# and all), is the client's and is printed beside it, not counted.
echo "-- 1080p sphere scene: POST /v1/render (cache miss) against the whole rayd-render process"
"$BUILD/rayd" --bind 127.0.0.1 --port 0 --threads 2 >"$tmp/rayd.out" 2>"$tmp/rayd.err" &
rp=$!
for _ in $(seq 1 200); do [ -s "$tmp/rayd.out" ] && break; sleep 0.05; done
url=$(sed -n 's/^rayd listening on //p' "$tmp/rayd.out")
cli=() http=() curlp=()
for k in $(seq 1 $((${RUNS:-3} * 3))); do
    { cat bench/scenes/spheres10.json; printf '%*s\n' "$k" ''; } >"$tmp/s$k.json"
    "$D/walltime" "$tmp/us" "$BUILD/rayd-render" "$tmp/s$k.json" -o "$tmp/cli.png" --threads 2
    cli+=("$(cat "$tmp/us")")
    "$D/walltime" "$tmp/us" curl -s -o "$tmp/http.png" -w '%{time_total}\n' \
        -H 'Content-Type: application/json' --data-binary @"$tmp/s$k.json" "$url/v1/render" \
        >"$tmp/tt"
    http+=("$(awk '{printf "%d", $1 * 1e6}' "$tmp/tt")")
    curlp+=("$(cat "$tmp/us")")
done
kill -TERM "$rp"
wait "$rp" || true
med() { printf '%s\n' "$@" | sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
c=$(med "${cli[@]}")
h=$(med "${http[@]}")
p=$(med "${curlp[@]}")
cmp -s "$tmp/cli.png" "$tmp/http.png" && same=identical || same=DIFFERENT
awk -v c="$c" -v h="$h" -v p="$p" -v s="$same" 'BEGIN {printf "rayd-render whole process %.3f s, POST /v1/render %.3f s: %.2fx (PNGs %s; the curl process %.3f s)\n", c / 1e6, h / 1e6, h / c, s, p / 1e6}'
