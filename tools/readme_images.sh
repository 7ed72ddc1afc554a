#!/usr/bin/env bash
# readme_images.sh [BUILD] -- renders the README's model pictures into
# docs/images/: model.png, a real model lit by the studio environment,
# model-turntable.png, the same model from six azimuths joined side by side,
# and animation-strip.png, six frames of scenes/animation.json.
#
# The model is Wuson.ply, a bison (Blender's "Wuson", 11184 vertices with
# normals) from Debian's assimp-testmodels (/usr/share/assimp/models/PLY/,
# BSD-3-clause, the ASSIMP Development Team; `make test-deps` installs it).
# It stands on a floor plane at y = 0 (its feet are at y = -0.0006), is
# placed by "camera": {"frame": "all"} with an azimuth and an elevation
# (docs/scene-format.md, "Automatic framing"; the floor, unbounded, is not
# framed), and is path-traced under scenes/studio.hdr.  The frames of the
# turntable are the same scene at azimuths 60 degrees apart, joined by
# tools/png_strip.py (python3's standard library only).  The model, the
# turntable and cornell.png (scenes/cornell.json at 32 samples instead of
# its 128) go through rayd's denoiser (--denoise), which is what lets
# them render in seconds.  Rendering is deterministic: the same build
# writes the same bytes.
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
RENDER=$BUILD/rayd-render
MODEL=/usr/share/assimp/models/PLY/Wuson.ply
OUT=docs/images
if [ ! -x "$RENDER" ]; then
    echo "readme_images.sh: error: no $RENDER (run make first)" >&2
    exit 1
fi
if [ ! -f "$MODEL" ]; then
    echo "readme_images.sh: error: no $MODEL (make test-deps installs assimp-testmodels)" >&2
    exit 1
fi
T=$(mktemp -d "${TMPDIR:-/tmp}/rayd-readme.XXXXXX")
trap 'rm -rf "$T"' EXIT
cp scenes/studio.hdr "$MODEL" "$T/"

# scene AZIMUTH WIDTH HEIGHT SAMPLES: the scene on stdout
scene() { sh tools/model_scene.sh "$@"; }

scene -125 400 260 32 >"$T/model.json"
"$RENDER" "$T/model.json" -o "$OUT/model.png" --denoise -q
frames=()
for k in 0 1 2 3 4 5; do
    scene $((-125 + 60 * k)) 150 110 16 >"$T/turn-$k.json"
    "$RENDER" "$T/turn-$k.json" -o "$T/turn-$k.png" --denoise -q
    frames+=("$T/turn-$k.png")
done
python3 tools/png_strip.py "$OUT/model-turntable.png" "${frames[@]}"

# The animated example (scenes/animation.json, tools/make_animation_scene.py):
# six of its 48 frames, 8 apart, at half its size, joined side by side.
python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); s["render"].update(width=160, height=90); print(json.dumps(s))' \
    scenes/animation.json >"$T/animation.json"
"$RENDER" "$T/animation.json" --frames 0-40 -o "$T/anim-%02d.png" -q
python3 tools/png_strip.py "$OUT/animation-strip.png" "$T"/anim-00.png "$T"/anim-08.png \
    "$T"/anim-16.png "$T"/anim-24.png "$T"/anim-32.png "$T"/anim-40.png
# The Cornell box of the example table: 32 samples, denoised.
python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); s["render"].update(samples=32); print(json.dumps(s))' \
    scenes/cornell.json >"$T/cornell.json"
"$RENDER" "$T/cornell.json" -o "$OUT/cornell.png" --denoise -q
ls -l "$OUT/model.png" "$OUT/model-turntable.png" "$OUT/animation-strip.png" "$OUT/cornell.png"
