#!/usr/bin/env bash
# bench/scenes.sh BUILD -- every example scene at 1920x1080, rayd-render's
# whole process (what a user waits for) beside its render time and the other
# stages of --stats (parse: the JSON; decode: mesh files; build: BVHs and
# light buffers; render: the tiles, with the PNG bands deflated as their rows
# are drawn; encode: the PNG after the render; enc cpu: the bands' deflating
# on all threads together, most of it inside the render's time; other:
# start-up, reads, write), with SPP
# samples per pixel (default 1; SPP="1 16" adds 16 samples, several
# minutes more) on 2 threads; median of RUNS runs (default 3).  One sample
# keeps the whole `make bench` within about 5 minutes on a busy 2-core
# machine however many example scenes there are.  SCENES="a.json b.json"
# picks the scenes (default: every scenes/*.json).
set -eu
BUILD=${1:-build}
RUNS=${RUNS:-3}
SPP=${SPP:-1}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '%-10s %7s %8s %8s %8s %8s %8s %8s %9s %8s %8s %14s\n' scene samples "whole s" "parse s" \
    "decode s" "build s" "render s" "encode s" "enc cpu s" "other s" "Mrays/s" "renders (s)"
median() { sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
for scene in ${SCENES:-scenes/*.json}; do
    name=$(basename "$scene" .json)
    for spp in $SPP; do
        python3 - "$scene" "$tmp/$name-$spp.json" "$spp" <<'PY'
import json, os, sys
d = json.load(open(sys.argv[1]))
d.setdefault("render", {}).update(width=1920, height=1080, samples=int(sys.argv[3]))
for o in d.get("objects", []):  # mesh files stay where the scene found them
    src = o.get("source") if isinstance(o, dict) else None
    if isinstance(src, dict) and "file" in src:
        src["file"] = os.path.join(os.path.dirname(os.path.abspath(sys.argv[1])), src["file"])
json.dump(d, open(sys.argv[2], "w"))
PY
        times=() rates=() wholes=() parses=() decodes=() builds=() encodes=() bands=()
        for _ in $(seq "$RUNS"); do
            out=$("$BUILD/bench/walltime" "$tmp/us" "$BUILD/rayd-render" "$tmp/$name-$spp.json" \
                -o "$tmp/out.png" --threads 2 --stats 2>&1)
            wholes+=("$(cat "$tmp/us")")
            times+=("$(awk '/^wall:/ {print $2}' <<<"$out")")
            parses+=("$(awk '/^time parse:/ {print $3}' <<<"$out")")
            decodes+=("$(awk '/^time decode:/ {print $3}' <<<"$out")")
            builds+=("$(awk '/^time build:/ {print $3}' <<<"$out")")
            encodes+=("$(awk '/^time encode:/ {print $3}' <<<"$out")")
            bands+=("$(awk '/^encode bands:/ {print $8}' <<<"$out")")
            rates+=("$(awk '/^rays\/s:/ {printf "%.2f", $2 / 1e6}' <<<"$out")")
        done
        med=$(printf '%s\n' "${times[@]}" | median)
        whole=$(printf '%s\n' "${wholes[@]}" | median | awk '{printf "%.3f", $1 / 1e6}')
        parse=$(printf '%s\n' "${parses[@]}" | median)
        dec=$(printf '%s\n' "${decodes[@]}" | median)
        bld=$(printf '%s\n' "${builds[@]}" | median)
        enc=$(printf '%s\n' "${encodes[@]}" | median)
        ecpu=$(printf '%s\n' "${bands[@]}" | median)
        other=$(awk -v w="$whole" -v p="$parse" -v d="$dec" -v b="$bld" -v r="$med" -v e="$enc" \
            'BEGIN {printf "%.3f", w - p - d - b - r - e}')
        mr=$(printf '%s\n' "${rates[@]}" | median)
        printf '%-10s %7s %8s %8.3f %8.3f %8.3f %8s %8.3f %9.3f %8s %8s   %s\n' "$name" "$spp" "$whole" \
            "$parse" "$dec" "$bld" "$med" "$enc" "$ecpu" "$other" "$mr" "${times[*]}"
    done
done
