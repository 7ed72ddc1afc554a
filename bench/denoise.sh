#!/usr/bin/env bash
# denoise.sh [BUILD] -- make bench-denoise: the denoiser's quality against a
# high-sample reference, beside the raw renders and two baselines
# (bench/denoise.c), on scenes/cornell.json and on a mesh (Wuson.ply from
# assimp-testmodels, as the README's picture) under scenes/studio.hdr.
# DENOISE_SIZE (default 128) is the Cornell box's edge in pixels,
# DENOISE_REF (default 4096) the reference's samples (2 to 3 minutes a
# scene at 128 pixels on two loaded cores; 256 pixels take four times
# that).  DENOISE_CACHE=DIR keeps the renders between runs, so a change of
# the filter is measured again in seconds; DENOISE_RUNS (default 5) the
# timing's runs.  Figures: bench/README.md.
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
SIZE=${DENOISE_SIZE:-128}
REF=${DENOISE_REF:-4096}
T=$(mktemp -d "${TMPDIR:-/tmp}/rayd-denoise.XXXXXX")
trap 'rm -rf "$T"' EXIT
python3 -c 'import json,sys; s=json.load(open("scenes/cornell.json")); s["render"].update(width=int(sys.argv[1]), height=int(sys.argv[1])); print(json.dumps(s))' "$SIZE" >"$T/cornell.json"
"$BUILD/bench/denoise" "$T/cornell.json" "$REF" "scenes/cornell.json"
MODEL=/usr/share/assimp/models/PLY/Wuson.ply
if [ -f "$MODEL" ]; then
    cp scenes/studio.hdr "$MODEL" "$T/"
    sh tools/model_scene.sh -125 $((SIZE * 3 / 2)) "$SIZE" 1 >"$T/model.json"
    "$BUILD/bench/denoise" "$T/model.json" "$REF" "Wuson.ply under scenes/studio.hdr"
else
    echo "denoise.sh: no $MODEL (make test-deps installs assimp-testmodels): the mesh is skipped" >&2
fi
