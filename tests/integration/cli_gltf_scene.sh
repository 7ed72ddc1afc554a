#!/usr/bin/env bash
# cli_gltf_scene.sh -- glTF 2.0 files others made, from Debian's
# assimp-testmodels, rendered by rayd-render as "gltf" objects (the file as
# a whole scene: its materials, textures, lights and cameras).  Each is
# framed from its bounds as cli_gltf.sh does (lib/gltf_frame.py).
#   - the textured boxes (.gltf with a .bin and a .png, .glb, embedded) show
#     their texture: many strongly coloured pixels, where the same file as a
#     mesh source (one grey material) shows none;
#   - files of many materials render and show more than one colour;
#   - Cameras.gltf through its own camera 0 (perspective) and 1
#     (orthographic) gives byte for byte the PNG of the same cameras written
#     by hand in /camera;
#   - a missing image file, a clash with /camera, a lens on the file's
#     orthographic camera and textures over the file's texel budget are
#     refused in one line naming the JSON Pointer;
#   - every other .gltf and .glb there renders or is refused in one line
#     with exit 1: never a crash or a hang.
# rayd-test: long
source "$(dirname "$0")/lib/common.sh"
DIR=/usr/share/assimp/models/glTF2
FRAME="$RAYD_ROOT/tests/integration/lib/gltf_frame.py"
LIB="$RAYD_ROOT/tests/integration/lib"
if [ ! -d "$DIR" ]; then
    fail assimp_testmodels_gltf_scene "missing $DIR (make test-deps installs assimp-testmodels)"
    exit 1
fi

# gscene FILE OUT [KEY=JSON...]: the framed scene of FILE with a gltf object
# (extra object keys, and /camera replaced when a key is camera_top=JSON);
# one python3 for both steps, as it runs once per file of the folder
gscene() {
    local f=$1 out=$2
    shift 2
    python3 -c '
import contextlib, io, json, sys
sys.path.insert(0, sys.argv.pop(1))
import gltf_frame
out = io.StringIO()
with contextlib.redirect_stdout(out):
    gltf_frame.scene(sys.argv.pop(1))
s = json.loads(out.getvalue())
o = s["objects"][0]
o["type"] = "gltf"
for kv in sys.argv[1:]:
    k, v = kv.split("=", 1)
    if k == "camera_top":
        s["camera"] = json.loads(v)
    elif k == "width":
        s["render"]["width"] = s["render"]["height"] = int(v)
    else:
        o[k] = json.loads(v)
print(json.dumps(s))' "$LIB" "$f" "$@" >"$out"
}

# colourful PNG: pixels whose channels differ by more than 60 (not grey)
colourful() {
    python3 -c '
import sys
sys.path.insert(0, sys.argv[1])
import gltf_frame as g
bpp, rows = g.rows(sys.argv[2])
w = len(rows[0]) // bpp
print(sum(1 for r in rows for x in range(w) if max(r[x*bpp:x*bpp+3]) - min(r[x*bpp:x*bpp+3]) > 60))' "$LIB" "$1"
}

# colours PNG: distinct colours among the lit pixels, rounded to 32 levels
colours() {
    python3 -c '
import sys
sys.path.insert(0, sys.argv[1])
import gltf_frame as g
bpp, rows = g.rows(sys.argv[2])
w = len(rows[0]) // bpp
print(len({tuple(c // 32 for c in r[x*bpp:x*bpp+3]) for r in rows for x in range(w) if max(r[x*bpp:x*bpp+3]) > 8}))' "$LIB" "$1"
}

# run NAME: renders $T/NAME.json to $T/NAME.png; sets rc, err, lit
run() {
    timeout 60 "$RENDER" "$T/$1.json" -o "$T/$1.png" -q 2>"$T/$1.err"
    rc=$?
    err=$(head -c 300 "$T/$1.err")
    lit=0
    [ $rc = 0 ] && lit=$(python3 "$FRAME" lit "$T/$1.png")
}

# The textured boxes show the texture; as a mesh source they are grey.
for f in BoxTextured-glTF/BoxTextured.gltf BoxTextured-glTF-Binary/BoxTextured.glb \
    BoxTextured-glTF-Embedded/BoxTextured.gltf BoxTexcoords-glTF/boxTexcoords.gltf; do
    name=$(echo "$f" | tr '/.' '__')
    gscene "$DIR/$f" "$T/$name.json" width=96
    run "$name"
    n=0
    [ $rc = 0 ] && n=$(colourful "$T/$name.png")
    check "gltf_scene_textured_$name" "exit $rc, $n colourful of $lit lit pixels: $err" \
        bash -c "[ $rc = 0 ] && [ $n -gt 300 ]"
done
python3 "$FRAME" scene "$DIR/BoxTextured-glTF/BoxTextured.gltf" >"$T/grey.json"
python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); s["render"]["width"]=s["render"]["height"]=96; json.dump(s,open(sys.argv[1],"w"))' "$T/grey.json"
run grey
n=$([ $rc = 0 ] && colourful "$T/grey.png" || echo -1)
check gltf_scene_mesh_source_stays_grey "exit $rc, $n colourful of $lit lit pixels: $err" \
    bash -c "[ $rc = 0 ] && [ $lit -gt 300 ] && [ $n = 0 ]"

# Files of many materials: more than one colour.
for f in 2CylinderEngine-glTF-Binary/2CylinderEngine.glb ClearCoat-glTF/ClearCoatTest.gltf \
    textureTransform/TextureTransformTest.gltf; do
    name=$(echo "$f" | tr '/.' '__')
    gscene "$DIR/$f" "$T/$name.json" width=96
    run "$name"
    c=0
    [ $rc = 0 ] && c=$(colours "$T/$name.png")
    check "gltf_scene_materials_$name" "exit $rc, $c colours, $lit lit pixels: $err" \
        bash -c "[ $rc = 0 ] && [ $lit -gt 100 ] && [ $c -gt 3 ]"
done

# The file's cameras against the same cameras by hand (yfov 0.7 rad, node at
# (0.5, 0.5, 3) looking down -Z; ymag 1 on a square image: view_width 2).
cp -r "$DIR/cameras" "$T/cameras"
for c in 0 1; do
    if [ $c = 0 ]; then
        hand='{"position": [0.5, 0.5, 3], "look_at": [0.5, 0.5, 2], "up": [0, 1, 0], "fov_y": 40.10704565915762}'
    else
        hand='{"position": [0.5, 0.5, 3], "look_at": [0.5, 0.5, 2], "up": [0, 1, 0], "projection": "orthographic", "view_width": 2}'
    fi
    gscene "$T/cameras/Cameras.gltf" "$T/cam$c.json" width=64 camera=$c
    python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); del s["camera"]; json.dump(s,open(sys.argv[1],"w"))' "$T/cam$c.json"
    gscene "$T/cameras/Cameras.gltf" "$T/hand$c.json" width=64 "camera_top=$hand"
    run "cam$c"
    rc1=$rc lit1=$lit
    run "hand$c"
    check "gltf_scene_camera_$c" "exits $rc1 $rc, $lit1 lit pixels: $err" \
        bash -c "[ $rc1 = 0 ] && [ $rc = 0 ] && [ $lit1 -gt 50 ] && cmp -s '$T/cam$c.png' '$T/hand$c.png'"
done
gscene "$T/cameras/Cameras.gltf" "$T/clash.json" camera=0
run clash
check gltf_scene_camera_clash "exit $rc: $err" \
    bash -c "[ $rc = 1 ] && grep -qF 'rayd-render: error: $T/clash.json: /objects/0/camera: the glTF camera sets the scene'\''s camera: /camera/position cannot be given too' '$T/clash.err'"

# A missing image file: the pointer of its uri.
mkdir -p "$T/noimg"
cp "$DIR/BoxTextured-glTF/BoxTextured.gltf" "$DIR/BoxTextured-glTF/BoxTextured0.bin" "$T/noimg/"
gscene "$T/noimg/BoxTextured.gltf" "$T/noimg.json"
run noimg
check gltf_scene_missing_image "exit $rc: $err" \
    bash -c "[ $rc = 1 ] && [ \$(wc -l <'$T/noimg.err') = 1 ] && grep -qF 'rayd-render: error: $T/noimg.json: /objects/0/source/gltf/images/0/uri: cannot open' '$T/noimg.err'"

# The texels of a file's textures together: one 4096 x 4096 image uses
# them all, so a small one after it is refused (the budget never reaches
# the PNG decoder as 0, which there means its own, larger default); two
# small ones render.
for sizes in "4096 2" "64 64"; do
    d="$T/texels-${sizes// /-}"
    mkdir -p "$d"
    python3 "$LIB/gltf_textures.py" "$d" $sizes
    timeout 60 "$RENDER" "$d/scene.json" -o "$d/out.png" -q 2>"$d/err"
    echo $? >"$d/rc"
done
check gltf_scene_texel_budget_refused "exit $(cat "$T/texels-4096-2/rc"): $(head -c 300 "$T/texels-4096-2/err")" \
    bash -c "[ \$(cat '$T/texels-4096-2/rc') = 1 ] && grep -q '/objects/0/source/gltf/images/1/uri: the textures together are over the limit (16777216 pixels a glTF file' '$T/texels-4096-2/err'"
check gltf_scene_texel_budget_small "exit $(cat "$T/texels-64-64/rc"): $(head -c 300 "$T/texels-64-64/err")" \
    bash -c "[ \$(cat '$T/texels-64-64/rc') = 0 ] && [ -s '$T/texels-64-64/out.png' ]"

# The scene's image textures together: four 4096 x 4096 images fill them,
# so a fifth gltf object naming the same file is refused at its image.
d="$T/texels-scene"
mkdir -p "$d"
python3 "$LIB/gltf_textures.py" "$d" 4096
python3 -c '
import json, sys
s = json.load(open(sys.argv[1]))
s["objects"] = s["objects"] * 5
json.dump(s, open(sys.argv[1], "w"))' "$d/scene.json"
timeout 120 "$RENDER" "$d/scene.json" -o "$d/out.png" -q 2>"$d/err"
rc=$?
check gltf_scene_scene_texel_budget "exit $rc: $(head -c 300 "$d/err")" \
    bash -c "[ $rc = 1 ] && grep -qF 'rayd-render: error: $d/scene.json: /objects/4/source/gltf/images/0/uri: the textures together are over the limit' '$d/err'"

# A lens on the file's orthographic camera is refused, as on a hand-written one.
mkdir -p "$T/orthoap"
cp "$DIR"/cameras/* "$T/orthoap/"
printf '{"camera": {"aperture": 0.5}, "render": {"width": 32, "height": 32},
 "objects": [{"type": "gltf", "source": {"file": "Cameras.gltf"}, "camera": 1}]}' >"$T/orthoap.json"
cp "$T/orthoap.json" "$T/orthoap/scene.json"
timeout 60 "$RENDER" "$T/orthoap/scene.json" -o "$T/orthoap.png" -q 2>"$T/orthoap.err"
rc=$?
check gltf_scene_ortho_aperture "exit $rc: $(head -c 300 "$T/orthoap.err")" \
    bash -c "[ $rc = 1 ] && grep -qF 'rayd-render: error: $T/orthoap/scene.json: /camera/aperture: must be 0' '$T/orthoap.err'"

# Every file: a render or a one-line refusal with exit 1, nothing worse.
while IFS= read -r f; do
    name=any_$(echo "$f" | tr '/.' '__')
    gscene "$DIR/$f" "$T/$name.json"
    run "$name"
    lines=$(wc -l <"$T/$name.err")
    if [ "$rc" = 0 ]; then
        check "gltf_scene_$name" "rendered but $lit lit pixels" [ "$lit" -gt 0 ]
    else
        check "gltf_scene_$name" "exit $rc, $lines lines: $err" \
            bash -c "[ $rc = 1 ] && [ $lines = 1 ] && grep -qF 'rayd-render: error: $T/$name.json: /objects/0/' '$T/$name.err'"
    fi
done < <(cd "$DIR" && find . -name '*.gltf' -o -name '*.glb' | sed 's|^\./||' | sort)
exit 0
