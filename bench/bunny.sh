#!/usr/bin/env bash
# bench/bunny.sh BUILD -- the Stanford bunny (npm package `bunny`, a real
# scanned mesh) as BUILD/bench/bunny.ply plus its scene bunny.json.  Needs
# node and the npm registry; without them it says so and exits 0, and the
# benchmarks go on without the bunny.
set -u
cd "$(dirname "$0")/.."
BUILD=${1:-build}
D=$BUILD/bench
[ -s "$D/bunny.json" ] && [ -s "$D/bunny.ply" ] && exit 0
if ! command -v npm >/dev/null || ! command -v node >/dev/null; then
    echo "bench: npm/node not installed: skipping the Stanford bunny"
    exit 0
fi
mkdir -p "$D/npm"
if ! timeout 120 npm install --prefix "$D/npm" --no-audit --no-fund --no-save --silent \
        bunny@1.0.1 >"$D/npm/install.log" 2>&1; then
    echo "bench: npm registry unreachable (see $D/npm/install.log): skipping the Stanford bunny"
    exit 0
fi
node bench/bunny2ply.js "$D/npm/node_modules/bunny" "$D/bunny.ply" &&
    python3 bench/mkscene.py "$D/bunny.ply" "$D/bunny.json" ||
    { echo "bench: could not convert the bunny: skipping it"; rm -f "$D/bunny.ply" "$D/bunny.json"; }
exit 0
