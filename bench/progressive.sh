#!/usr/bin/env bash
# bench/progressive.sh BUILD -- issue 17's figures: the Cornell box rendered
# progressively, time to each pass, in rayd-render (--passes) and over HTTP
# (a progressive job followed on its event stream, bench/progressive.py),
# at 320x320 and 1280x720, 128 samples.  Run by bench/run.sh (`make bench`);
# RUNS (default 3) runs each, medians printed.
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
RUNS=${RUNS:-3}
T=$(mktemp -d)
RPID=
cleanup() { [ -n "$RPID" ] && kill "$RPID" 2>/dev/null; wait 2>/dev/null; rm -rf "$T"; }
trap cleanup EXIT

"$BUILD/rayd" --bind 127.0.0.1 --port 0 --threads 2 --result-cache-mb 0 >"$T/out" 2>/dev/null &
RPID=$!
URL=
for _ in $(seq 1 100); do
    URL=$(sed -n 's/^rayd listening on //p' "$T/out")
    [ -n "$URL" ] && break
    sleep 0.05
done
[ -n "$URL" ] || { echo "bench/progressive.sh: rayd did not start"; exit 1; }

for size in 320x320 1280x720; do
    python3 - "$T/c.json" "$size" <<'PY'
import json, sys
s = json.load(open("scenes/cornell.json"))
w, h = (int(x) for x in sys.argv[2].split("x"))
s["render"].update(width=w, height=h, samples=128)
open(sys.argv[1], "w").write(json.dumps(s))
PY
    echo "-- rayd-render --passes --threads 2, $size (seconds since the first pass started)"
    for r in $(seq 1 "$RUNS"); do
        "$BUILD/rayd-render" "$T/c.json" -o "$T/c.png" --passes --threads 2 2>&1 | grep -i pass | tr '\n' ' '
        echo
    done
    echo "-- over HTTP, $size"
    python3 bench/progressive.py "$URL" "$T/c.json" "$size" "$RUNS"
done

# The merged-samples overhead: one frame through rayd-client on this one
# node, as tiles and as --split-samples 4 (each range the whole image's
# sums, 24 bytes a pixel, added up by the client); a fresh seed each run.
echo "-- rayd-client on one node: tiles against --split-samples 4 (seconds, medians of $RUNS)"
for size in 320x320 1280x720; do
    tiles=() ranges=()
    for r in $(seq 1 "$RUNS"); do
        for mode in tiles ranges; do
            python3 - "$T/m.json" "$size" "$r$mode" <<'PY'
import json, sys
s = json.load(open("scenes/cornell.json"))
w, h = (int(x) for x in sys.argv[2].split("x"))
s["render"].update(width=w, height=h, samples=32, seed=hash(sys.argv[3]) % 100000)
open(sys.argv[1], "w").write(json.dumps(s))
PY
            extra=()
            [ $mode = ranges ] && extra=(--split-samples 4)
            t0=$(date +%s.%N)
            "$BUILD/rayd-client" render "$T/m.json" -o "$T/m.png" --server "$URL" -q "${extra[@]}"
            t1=$(date +%s.%N)
            dt=$(python3 -c "print($t1 - $t0)")
            if [ $mode = tiles ]; then tiles+=("$dt"); else ranges+=("$dt"); fi
        done
    done
    python3 - "$size" "${tiles[*]}" "${ranges[*]}" <<'PY'
import statistics, sys
t = statistics.median(float(x) for x in sys.argv[2].split())
r = statistics.median(float(x) for x in sys.argv[3].split())
print("%s, 32 samples: tiles %.3f s, 4 sample ranges %.3f s, ranges / tiles %.3f" % (sys.argv[1], t, r, r / t))
PY
done
