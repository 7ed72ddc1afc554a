#!/usr/bin/env bash
# cli_gltf.sh -- glTF 2.0 files others made, from Debian's assimp-testmodels
# (make test-deps installs it), rendered by rayd-render through a mesh
# "source": {"file": ...}.  Each good file is framed from its own bounds
# (tests/integration/lib/gltf_frame.py reads the node tree and the
# accessors' min and max) and its PNG must show the mesh (pixels other than
# the black background).  Each hostile or odd file must give the expected
# one-line error, naming the JSON Pointer inside the glTF document, with
# exit 1.  Then every other .gltf and .glb there either renders or is
# refused in one line with exit 1: never a crash (exit >= 128) or a hang
# (timeout).  Last, a .gltf and its .bin under rayd's --asset-dir, and a
# .gltf whose buffer leads out of it.
source "$(dirname "$0")/lib/common.sh"
DIR=/usr/share/assimp/models/glTF2
FRAME="$RAYD_ROOT/tests/integration/lib/gltf_frame.py"
if [ ! -d "$DIR" ]; then
    fail assimp_testmodels_gltf "missing $DIR (make test-deps installs assimp-testmodels)"
    exit 1
fi

# render FILE NAME: writes $T/NAME.json, renders it; sets rc, err, lit
render() {
    python3 "$FRAME" scene "$1" >"$T/$2.json" 2>"$T/$2.frame" || true
    timeout 60 "$RENDER" "$T/$2.json" -o "$T/$2.png" -q 2>"$T/$2.err"
    rc=$?
    err=$(head -c 300 "$T/$2.err")
    lit=0
    [ $rc = 0 ] && lit=$(python3 "$FRAME" lit "$T/$2.png")
}

declare -A done_files
good() { # FILE: renders, and shows something
    local f=$1 name
    name=$(echo "$f" | tr '/.' '__')
    done_files[$f]=1
    render "$DIR/$f" "$name"
    check "gltf_renders_$name" "exit $rc, $lit lit pixels: $err" bash -c "[ $rc = 0 ] && [ $lit -gt 0 ]"
}
bad() { # FILE MESSAGE: refused in one line with the pointer and message
    local f=$1 want=$2 name lines
    name=$(echo "$f" | tr '/.' '__')
    done_files[$f]=1
    render "$DIR/$f" "$name"
    lines=$(wc -l <"$T/$name.err")
    check "gltf_refuses_$name" "exit $rc, $lines lines: $err (want: $want)" \
        bash -c "[ $rc = 1 ] && [ $lines = 1 ] && grep -qF -- \"\$1\" '$T/$name.err'" _ "rayd-render: error: $T/$name.json: $want"
}

good 2CylinderEngine-glTF-Binary/2CylinderEngine.glb
good BoxTextured-glTF-Binary/BoxTextured.glb
good BoxTextured-glTF-Embedded/BoxTextured.gltf
good BoxTextured-glTF/BoxTextured.gltf
good BoxTexcoords-glTF/boxTexcoords.gltf
good BoxBadNormals-glTF-Binary/BoxBadNormals.glb
good cameras/Cameras.gltf
good glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf
good simple_skin/simple_skin.gltf
good IncorrectVertexArrays/Cube.gltf
for m in 04 05 06 11 12 13 14 15; do good glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_$m.gltf; done
bad IndexOutOfRange/IndexOutOfRange.gltf "/objects/0/source/gltf/accessors/0: element 0 is 255, out of range"
bad IndexOutOfRange/AllIndicesOutOfRange.gltf "/objects/0/source/gltf/accessors/0: element 0 is 65535, out of range"
bad RecursiveNodes/RecursiveNodes.gltf "/objects/0/source/gltf/nodes/1/children/0: node 0 is its own ancestor"
bad MissingBin/BoxTextured.gltf "/objects/0/source/gltf/buffers/0/uri: cannot open"
bad BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb "/objects/0/source/gltf/accessors/2: POSITION 0 is not finite"
bad SchemaFailures/sceneWrongType.gltf "/objects/0/source/gltf/scene: must be an integer"
bad TestNoRootNode/NoScene.gltf "/objects/0/source/gltf: no triangles"
bad TestNoRootNode/SceneWithoutNodes.gltf "/objects/0/source/gltf: no triangles"
bad draco/2CylinderEngine.gltf "/objects/0/source/gltf/extensionsRequired/0: KHR_draco_mesh_compression: compressed meshes are not supported"
bad BoxTextured-glTF-techniqueWebGL/BoxTextured.gltf "/objects/0/source/gltf/extensionsRequired/0: required extension \"KHR_technique_webgl\" is not supported"
bad wrongTypes/badArray.gltf "/objects/0/source/gltf/meshes/0/primitives: must be an array"
for m in 00 01 02 03 07 08 09 10; do bad glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_$m.gltf "/objects/0/source/gltf: no triangles"; done

# glTF 1.0 files from assimp's glTF folder: one says "version": 1 (a number),
# and is named as glTF 1 all the same, not as a wrong type
V1=/usr/share/assimp/models/glTF/CesiumMilkTruck/CesiumMilkTruck.gltf
render "$V1" gltf1_number_version
check gltf_refuses_version_number_as_gltf1 "exit $rc: $err" bash -c \
    "[ $rc = 1 ] && grep -qF 'source/gltf/asset/version: glTF 1 is not supported (2.x is)' '$T/gltf1_number_version.err'"

# The same files embedded in the scene: a .glb as base64, a .gltf as text.
embed() { # FILE FORMAT KEY NAME
    python3 - "$1" "$2" "$3" "$FRAME" >"$T/$4.json" <<'PY'
import base64, json, subprocess, sys
f, fmt, key, frame = sys.argv[1:]
s = json.loads(subprocess.run(["python3", frame, "scene", f], capture_output=True, text=True).stdout)
data = open(f, "rb").read()
s["objects"][0]["source"] = {"format": fmt, key: base64.b64encode(data).decode() if key == "base64" else data.decode()}
print(json.dumps(s))
PY
    timeout 60 "$RENDER" "$T/$4.json" -o "$T/$4.png" -q 2>"$T/$4.err"
    rc=$?
    lit=0
    [ $rc = 0 ] && lit=$(python3 "$FRAME" lit "$T/$4.png")
    check "gltf_embedded_$4" "exit $rc, $lit lit pixels: $(head -c 300 "$T/$4.err")" bash -c "[ $rc = 0 ] && [ $lit -gt 0 ]"
}
embed "$DIR/BoxTextured-glTF-Binary/BoxTextured.glb" glb base64 glb_base64
embed "$DIR/BoxTextured-glTF-Embedded/BoxTextured.gltf" gltf text gltf_text
embed "$DIR/BoxTextured-glTF-Embedded/BoxTextured.gltf" gltf base64 gltf_base64

# Every other file: a render or a one-line refusal with exit 1, nothing worse.
while IFS= read -r f; do
    [ -n "${done_files[$f]:-}" ] && continue
    name=$(echo "$f" | tr '/.' '__')
    render "$DIR/$f" "$name"
    lines=$(wc -l <"$T/$name.err")
    if [ "$rc" = 0 ]; then
        check "gltf_any_$name" "rendered but $lit lit pixels" [ "$lit" -gt 0 ]
    else
        check "gltf_any_$name" "exit $rc, $lines lines: $err" \
            bash -c "[ $rc = 1 ] && [ $lines = 1 ] && grep -qF 'rayd-render: error: $T/$name.json: /objects/0/source/' '$T/$name.err'"
    fi
done < <(cd "$DIR" && find . -name '*.gltf' -o -name '*.glb' | sed 's|^\./||' | sort)

# The server reads a .gltf and its .bin inside --asset-dir, and nothing outside.
mkdir -p "$T/assets/box" "$T/outside"
cp "$DIR/BoxTextured-glTF/BoxTextured.gltf" "$DIR/BoxTextured-glTF/BoxTextured0.bin" "$T/assets/box/"
sed 's|"BoxTextured0.bin"|"../../outside/BoxTextured0.bin"|' "$DIR/BoxTextured-glTF/BoxTextured.gltf" >"$T/assets/escape.gltf"
cp "$DIR/BoxTextured-glTF/BoxTextured0.bin" "$T/outside/"
start_rayd --asset-dir "$T/assets"
for f in box/BoxTextured.gltf escape.gltf; do
    python3 "$FRAME" scene "$T/assets/$f" | sed "s|$T/assets/||" >"$T/srv.json"
    code=$(curl -s -o "$T/srv.out" -w '%{http_code}' --data-binary @"$T/srv.json" \
        -H 'Content-Type: application/json' "$URL/v1/render")
    body=$(head -c 300 "$T/srv.out" | tr -d '\0')
    if [ "$f" = escape.gltf ]; then
        check gltf_server_confines_buffers "HTTP $code: $body" \
            bash -c "[ $code = 422 ] && grep -q '\"path\":\"/objects/0/source/gltf/buffers/0/uri\"' '$T/srv.out' && grep -q 'must not contain a' '$T/srv.out'"
    else
        check gltf_server_reads_bin_in_asset_dir "HTTP $code: $body" \
            bash -c "[ $code = 200 ] && [ \$(python3 '$FRAME' lit '$T/srv.out') -gt 0 ]"
    fi
done
# rayd-client inlines a .glb file source as base64 with its format.  It
# sends only files in the scene's own folder (named relatively), so the
# model is copied beside the scene.
cp "$DIR/BoxTextured-glTF-Binary/BoxTextured.glb" "$T/BoxTextured.glb"
python3 "$FRAME" scene "$T/BoxTextured.glb" | sed "s#\"$T/BoxTextured.glb\"#\"BoxTextured.glb\"#" >"$T/client.json"
grep -q '"file": *"BoxTextured.glb"' "$T/client.json" || echo "FAIL gltf_client_scene: $(head -c 300 "$T/client.json")"
timeout 60 "$RAYD_BUILD/rayd-client" render "$T/client.json" -o "$T/client.png" --server "$URL" -q 2>"$T/client.err"
rc=$?
lit=0
[ $rc = 0 ] && lit=$(python3 "$FRAME" lit "$T/client.png")
check gltf_client_inlines_glb "exit $rc, $lit lit pixels: $(head -c 300 "$T/client.err")" bash -c "[ $rc = 0 ] && [ $lit -gt 0 ]"
stop_rayd
exit 0
