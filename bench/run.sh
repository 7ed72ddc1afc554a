#!/usr/bin/env bash
# bench/run.sh BUILD -- every benchmark; `make bench` runs it.  Figures are
# medians over several runs; compare ratios measured in the same run.
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
for b in bench/meshes.sh bench/scenes.sh bench/http.sh bench/scaleout.sh; do
    [ -f "$b" ] || continue
    echo "== $b"
    bash "$b" "$BUILD"
done
