#!/usr/bin/env bash
# bench/run.sh BUILD -- every benchmark; `make bench` runs it.  Figures are
# medians over several runs (RUNS, default 3); compare ratios measured in
# the same run.  The example scenes (bench/scenes.sh) get SCENE_RUNS runs,
# default 1: some take a minute at 1920x1080, and `make bench` should stay
# within about 5 minutes on 2 cores.
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
for b in bench/meshes.sh bench/scenes.sh bench/whole.sh bench/progressive.sh bench/durable.sh bench/frames.sh bench/latency.sh bench/http.sh bench/scaleout.sh; do
    [ -f "$b" ] || continue
    echo "== $b"
    if [ "$b" = bench/scenes.sh ]; then
        RUNS=${SCENE_RUNS:-1} bash "$b" "$BUILD"
    else
        bash "$b" "$BUILD"
    fi
done
