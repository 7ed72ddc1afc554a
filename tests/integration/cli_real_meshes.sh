#!/usr/bin/env bash
# cli_real_meshes.sh -- mesh files others made, from Debian's
# assimp-testmodels (make test-deps installs it): every PLY there is either a
# mesh rayd loads and shows (its render differs from the empty scene's) or
# a point cloud refused as one, with the JSON Pointer of the file; Blender
# 2.4x's header line without "comment" (Wuson.ply) is read as a comment.
source "$(dirname "$0")/lib/common.sh"
DIR=/usr/share/assimp/models/PLY
PNGCMP=$RAYD_BUILD/tests/tools/pngcmp
if [ ! -d "$DIR" ]; then
    fail assimp_testmodels "missing $DIR (make test-deps installs assimp-testmodels)"
    exit 1
fi

# framed FILE OUT: a scene of the file (or of nothing) seen from (4, 3, 6)
framed() {
    python3 - "$1" "$2" <<'PY'
import json, sys
objs = [{"type": "mesh", "source": {"file": sys.argv[1]}}] if sys.argv[1] else []
s = {"render": {"width": 64, "height": 48}, "camera": {"position": [4, 3, 6], "look_at": [0, 0.5, 0]},
     "lights": [{"type": "point", "position": [5, 8, 5]}], "objects": objs}
open(sys.argv[2], "w").write(json.dumps(s))
PY
}
framed "" "$T/empty.json"
"$RENDER" "$T/empty.json" -o "$T/empty.png"

for name in cube cube_binary cube_uv float-color Wuson; do
    framed "$DIR/$name.ply" "$T/$name.json"
    "$RENDER" "$T/$name.json" -o "$T/$name.png" 2>"$T/$name.err"
    rc=$?
    check "${name}_loads" "exit $rc: $(head -c 200 "$T/$name.err")" [ $rc = 0 ]
    check "${name}_is_seen" "the render equals the empty scene's" \
        bash -c "[ -s '$T/$name.png' ] && ! '$PNGCMP' '$T/empty.png' '$T/$name.png' 2>/dev/null"
done
for name in points pond.0 issue623; do
    framed "$DIR/$name.ply" "$T/$name.json"
    "$RENDER" "$T/$name.json" -o "$T/$name.png" 2>"$T/$name.err"
    rc=$?
    check "${name}_point_cloud" "exit $rc: $(head -c 300 "$T/$name.err")" bash -c \
        "[ $rc != 0 ] && grep -q '/objects/0/source/file: PLY header: no .face. or .tristrips. element (a point cloud, not a mesh)' '$T/$name.err' && [ ! -e '$T/$name.png' ]"
done
