#!/usr/bin/env bash
# bench/scenes.sh BUILD -- render time of every example scene at 1920x1080
# with SPP samples per pixel (default 1; SPP="1 16" adds 16 samples, several
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
printf '%-10s %7s %10s %12s %14s\n' scene samples "median s" "Mrays/s" "runs (s)"
for scene in ${SCENES:-scenes/*.json}; do
    name=$(basename "$scene" .json)
    for spp in $SPP; do
        python3 - "$scene" "$tmp/$name-$spp.json" "$spp" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
d.setdefault("render", {}).update(width=1920, height=1080, samples=int(sys.argv[3]))
json.dump(d, open(sys.argv[2], "w"))
PY
        times=() rates=()
        for _ in $(seq "$RUNS"); do
            out=$("$BUILD/rayd-render" "$tmp/$name-$spp.json" -o "$tmp/out.png" --threads 2 --stats 2>&1)
            times+=("$(awk '/^wall:/ {print $2}' <<<"$out")")
            rates+=("$(awk '/^rays\/s:/ {printf "%.2f", $2 / 1e6}' <<<"$out")")
        done
        med=$(printf '%s\n' "${times[@]}" | sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}')
        mr=$(printf '%s\n' "${rates[@]}" | sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}')
        printf '%-10s %7s %10s %12s   %s\n' "$name" "$spp" "$med" "$mr" "${times[*]}"
    done
done
