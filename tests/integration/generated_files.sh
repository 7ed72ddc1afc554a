#!/usr/bin/env bash
# generated_files.sh -- the committed files that tools/ scripts write are
# what those scripts write today, byte for byte: scenes/sky.hdr and its
# copy in scenes/environment.json (tools/make_sky_hdr.py), scenes/studio.hdr,
# scenes/studio.json and programs/client/studio_hdr.h (tools/make_studio_hdr.py),
# scenes/gltf.json (tools/make_gltf_scene.py), scenes/animation.json
# (tools/make_animation_scene.py).  A hand edit of one of them,
# or a script changed without rerunning it, is a FAIL naming the command
# that rewrites the file.
#
# The scripts write into the current folder (scenes/, programs/client/), so they run
# in a scratch folder with a copy of what they edit in place; the work tree
# is never touched.
source "$(dirname "$0")/lib/common.sh"
cd "$RAYD_ROOT" || exit 1
G=$T/gen
mkdir -p "$G/scenes" "$G/programs/client"
cp scenes/environment.json "$G/scenes/" # make_sky_hdr.py --scene edits it

# gen NAME COMMAND...: runs a generator in $G; FAIL if it fails
gen() {
    local name=$1; shift
    if (cd "$G" && "$@") >"$T/$name.out" 2>&1; then
        return 0
    fi
    fail "generate_$name" "$* failed: $(tr '\n' '|' <"$T/$name.out" | head -c 300)"
    return 1
}

# same FILE HOW: the regenerated FILE equals the committed one
same() {
    if [ ! -f "$G/$1" ]; then
        fail "generated_$1" "$2 did not write $1"
    elif cmp -s "$G/$1" "$1"; then
        pass "generated_$1"
    else
        fail "generated_$1" "differs from what '$2' writes; rerun it (and commit) or fix the script"
    fi
}

if gen sky python3 "$RAYD_ROOT/tools/make_sky_hdr.py" --scene; then
    same scenes/sky.hdr "python3 tools/make_sky_hdr.py --scene"
    same scenes/environment.json "python3 tools/make_sky_hdr.py --scene"
fi
if gen studio python3 "$RAYD_ROOT/tools/make_studio_hdr.py" --scene; then
    same scenes/studio.hdr "python3 tools/make_studio_hdr.py --scene"
    same scenes/studio.json "python3 tools/make_studio_hdr.py --scene"
    same programs/client/studio_hdr.h "python3 tools/make_studio_hdr.py --scene"
fi
if gen gltf python3 "$RAYD_ROOT/tools/make_gltf_scene.py"; then
    same scenes/gltf.json "python3 tools/make_gltf_scene.py"
fi
if gen animation python3 "$RAYD_ROOT/tools/make_animation_scene.py"; then
    same scenes/animation.json "python3 tools/make_animation_scene.py"
fi
exit 0
