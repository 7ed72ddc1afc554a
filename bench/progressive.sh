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
