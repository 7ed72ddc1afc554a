#!/usr/bin/env bash
# client_gltf.sh -- rayd-client sends a .gltf with its own files.  A .gltf
# names its buffers (.bin) and images by relative URIs; a server reads no
# client files, so the client rewrites them as data: URIs (gltf_bundle.c).
# For .gltf files others made (Debian's assimp-testmodels) in a scene
# "source": {"file": ...}, the PNG rendered over a rayd without an asset
# folder must be the bytes rayd-render makes reading the files from disk;
# the body the client posts carries each file's exact bytes under the
# right MIME type (a capture server reads it); a name with %20 is decoded;
# names that lead out of the .gltf's folder (.., %2e%2e, an absolute path,
# a symbolic link), a URL and a missing file are refused before anything
# is sent, in one line naming the .gltf, the JSON Pointer and the file
# (that line alone: no summary of the scene's files follows it).
# A .gltf given as "text" in the scene has its files next to the scene.
# A whole-scene "gltf" object's source travels the same way.  A bad file
# the client inlines (a PLY, an environment map) is reported at the scene's
# "file" key, in rayd-render's words.
# `thumbnails` does the same with a folder holding a .gltf: its thumbnail
# equals the one of the same model as a .glb.
source "$(dirname "$0")/lib/common.sh"
CLIENT=$RAYD_BUILD/rayd-client
A=/usr/share/assimp/models/glTF2
if [ ! -d "$A/BoxTextured-glTF" ]; then
    fail assimp_testmodels "missing $A (make test-deps installs assimp-testmodels)"
    exit 1
fi

# scene DIR FILE: a framed scene of one mesh source "file": FILE in DIR
scene() {
    printf '{"camera": {"frame": "all", "fov_y": 35},
  "render": {"width": 64, "height": 48, "samples": 2},
  "lights": [{"type": "point", "position": [3, 5, 4]}],
  "objects": [{"type": "mesh", "source": {"file": "%s"}}]}\n' "$2" >"$1/scene.json"
}

start_rayd --threads 2
for model in BoxTextured-glTF/BoxTextured BoxTexcoords-glTF/boxTexcoords \
    ClearCoat-glTF/ClearCoatTest glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube; do
    name=$(basename "$model")
    dir="$T/$name"
    cp -r "$A/$(dirname "$model")" "$dir"
    scene "$dir" "$name.gltf"
    "$RENDER" "$dir/scene.json" -o "$dir/local.png" -q 2>"$dir/local.err"
    "$CLIENT" render "$dir/scene.json" -o "$dir/remote.png" -s "$URL" -q 2>"$dir/remote.err"
    rc=$?
    check "client_gltf_same_png_$name" \
        "exit $rc: $(head -c 400 "$dir/remote.err") $(head -c 200 "$dir/local.err")" \
        bash -c "[ $rc = 0 ] && [ -s '$dir/local.png' ] && cmp -s '$dir/local.png' '$dir/remote.png'"
done

# a whole-scene gltf object (materials and the texture from the file)
# travels the same way: the textured box over rayd is rayd-render's bytes
dir="$T/BoxTextured"
sed 's/"type": "mesh"/"type": "gltf"/' "$dir/scene.json" >"$dir/object.json"
"$RENDER" "$dir/object.json" -o "$dir/object-local.png" -q 2>"$dir/object-local.err"
"$CLIENT" render "$dir/object.json" -o "$dir/object-remote.png" -s "$URL" -q 2>"$dir/object.err"
rc=$?
check client_gltf_object_same_png "exit $rc: $(head -c 400 "$dir/object.err") $(head -c 200 "$dir/object-local.err")" \
    bash -c "[ $rc = 0 ] && [ -s '$dir/object-local.png' ] && cmp -s '$dir/object-local.png' '$dir/object-remote.png'"
check client_gltf_object_textured "the gltf object drew the same image as the baked mesh" \
    bash -c "! cmp -s '$dir/object-local.png' '$dir/local.png'"

# errors_of SCENE: rayd-render's and rayd-client's errors for SCENE (no
# server: the client's own check) into $dir/local.err and $dir/remote.err;
# rc is the client's exit status
errors_of() {
    "$RENDER" "$1" -o "$dir/local.png" -q 2>"$dir/local.err"
    "$CLIENT" render "$1" -o "$dir/remote.png" -s http://127.0.0.1:9 --retries 0 -q \
        2>"$dir/remote.err"
    rc=$?
}

# 2CylinderEngine as a .gltf is Draco-compressed: bundled, it is refused by
# the client's local check with rayd-render's own message and pointer
dir="$T/draco"
cp -r "$A/draco" "$dir"
scene "$dir" 2CylinderEngine.gltf
errors_of "$dir/scene.json"
want=$(sed "s|^rayd-render: error: $dir/scene.json: ||" "$dir/local.err")
got=$(sed "s|^rayd-client: error: $dir/scene.json: invalid_scene: ||" "$dir/remote.err")
if [ $rc = 1 ] && [ -n "$want" ] && [ "$got" = "$want" ] && [[ $want == *KHR_draco* ]]; then
    pass client_gltf_draco_same_error
else
    fail client_gltf_draco_same_error "exit $rc: '$got' against '$want'"
fi

# a bad file the client inlines as base64 is reported at the scene's "file",
# as rayd-render reports it, not at the "base64" key the client wrote
dir="$T/inlined"
mkdir "$dir"
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n' >"$dir/bad.ply"
printf 'not an image\n' >"$dir/sky.hdr"
printf '{"objects": [{"type": "mesh", "source": {"file": "bad.ply"}}]}\n' >"$dir/ply.json"
printf '{"render": {"environment": {"file": "sky.hdr"}}}\n' >"$dir/env.json"
# a key with "/" and "~" is escaped in the pointer ("~1", "~0") as the core escapes it
printf 'not a png\n' >"$dir/tex.png"
printf '{"materials": {"wall/2~b": {"texture": {"type": "image", "file": "tex.png"}}},
  "objects": [{"type": "sphere", "radius": 1, "material": "wall/2~b"}]}\n' >"$dir/tex.json"
for s in ply env tex; do
    errors_of "$dir/$s.json"
    want=$(sed "s|^rayd-render: error: $dir/$s.json: ||" "$dir/local.err")
    got=$(sed "s|^rayd-client: error: $dir/$s.json: invalid_scene: ||" "$dir/remote.err")
    if [ $rc = 1 ] && [ -n "$want" ] && [ "$got" = "$want" ] && [[ $want == */file:* ]]; then
        pass "client_inlined_${s}_error_at_file"
    else
        fail "client_inlined_${s}_error_at_file" "exit $rc: '$got' against '$want'"
    fi
done

# a file the scene names that is missing: the same line as rayd-render's,
# the scene's file first, at the "file" key, the name as the scene gives it
printf '{"render": {"environment": {"file": "gone.hdr"}}}\n' >"$dir/gone.json"
errors_of "$dir/gone.json"
want=$(sed 's/^rayd-render: //' "$dir/local.err")
got=$(sed 's/^rayd-client: //' "$dir/remote.err")
if [ $rc = 1 ] && [ "$got" = "$want" ] &&
    [ "$want" = "error: $dir/gone.json: /render/environment/file: cannot open \"gone.hdr\": No such file or directory" ]; then
    pass client_missing_file_as_rayd_render
else
    fail client_missing_file_as_rayd_render "exit $rc: '$got' against '$want'"
fi
# ... and a short name in the working folder, which "cannot open" itself holds
printf '{"render": {"environment": {"file": "n"}}}\n' >"$dir/n.json"
(cd "$dir" && "$CLIENT" render n.json -o n.png -s http://127.0.0.1:9 --retries 0 -q 2>n.err)
check_line=$(cat "$dir/n.err")
if [ "$check_line" = "rayd-client: error: n.json: /render/environment/file: cannot open \"n\": No such file or directory" ]; then
    pass client_missing_short_name
else
    fail client_missing_short_name "'$check_line'"
fi

# a buffer whose name has a space, written %20 in the URI
dir="$T/space"
mkdir "$dir"
cp "$A/BoxTextured-glTF/BoxTextured0.bin" "$dir/box buffer.bin"
cp "$A/BoxTextured-glTF/CesiumLogoFlat.png" "$dir/"
sed 's/"BoxTextured0.bin"/"box%20buffer.bin"/' "$A/BoxTextured-glTF/BoxTextured.gltf" >"$dir/box.gltf"
scene "$dir" box.gltf
"$RENDER" "$dir/scene.json" -o "$dir/local.png" -q
"$CLIENT" render "$dir/scene.json" -o "$dir/remote.png" -s "$URL" -q 2>"$dir/remote.err"
check client_gltf_percent_decoded "$(cat "$dir/remote.err")" \
    bash -c "[ -s '$dir/local.png' ] && cmp -s '$dir/local.png' '$dir/remote.png'"
cmp -s "$dir/local.png" "$T/BoxTextured/local.png"
check client_gltf_percent_same_model "the renamed buffer drew another image" [ $? = 0 ]

# a .gltf given as "text" in the scene: its files are next to the scene
dir="$T/BoxTextured"
python3 - "$dir" <<'EOF'
import json, sys
d = sys.argv[1]
scene = json.load(open(d + "/scene.json"))
text = open(d + "/BoxTextured.gltf").read()
scene["objects"][0]["source"] = {"format": "gltf", "text": text}
json.dump(scene, open(d + "/text.json", "w"))
scene["objects"][0]["source"]["text"] = text.replace("BoxTextured0.bin", "gone.bin")
json.dump(scene, open(d + "/text-gone.json", "w"))
EOF
"$RENDER" "$dir/text.json" -o "$dir/text-local.png" -q
"$CLIENT" render "$dir/text.json" -o "$dir/text-remote.png" -s "$URL" -q 2>"$dir/text.err"
check client_gltf_text_source_same_png "$(cat "$dir/text.err")" \
    bash -c "[ -s '$dir/text-local.png' ] && cmp -s '$dir/text-local.png' '$dir/text-remote.png' &&
        cmp -s '$dir/text-local.png' '$dir/local.png'"
"$CLIENT" render "$dir/text-gone.json" -o "$dir/text-gone.png" -s "$URL" -q 2>"$dir/text-gone.err"
rc=$?
got=$(cat "$dir/text-gone.err") # the one line, no summary after it
want="rayd-client: error: $dir/text-gone.json: /objects/0/source/text: /buffers/0/uri: cannot read \"gone.bin\": No such file or directory"
if [ "$rc" = 1 ] && [ "$got" = "$want" ]; then
    pass client_gltf_text_source_missing
else
    fail client_gltf_text_source_missing "exit $rc: $got"
fi
stop_rayd

# What the client posts: a capture server keeps the first body and refuses it.
cat >"$T/capture.py" <<'EOF'
import http.server, sys
class H(http.server.BaseHTTPRequestHandler):
    def do_POST(self):
        body = self.rfile.read(int(self.headers["Content-Length"]))
        with open(sys.argv[2], "wb") as f:
            f.write(body)
        msg = b'{"error": {"code": "invalid_scene", "message": "captured", "path": ""}}'
        self.send_response(422)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(msg)))
        self.end_headers()
        self.wfile.write(msg)
    def log_message(self, *a):
        pass
s = http.server.HTTPServer(("127.0.0.1", 0), H)
with open(sys.argv[1], "w") as f:
    f.write(str(s.server_address[1]))
s.handle_request()
EOF
python3 "$T/capture.py" "$T/capture.port" "$T/body.json" &
CAP=$!
PIDS+=("$CAP")
wait_until 20 test -s "$T/capture.port"
"$CLIENT" render "$T/BoxTextured/scene.json" -o "$T/cap.png" -s "http://127.0.0.1:$(cat "$T/capture.port")" \
    --retries 0 -q 2>"$T/cap.err"
wait "$CAP"
cat >"$T/body_check.py" <<'EOF'
import base64, json, sys
scene = json.load(open(sys.argv[1]))
src = scene["objects"][0]["source"]
gltf = json.loads(src["text"])
d = sys.argv[2]
def data(uri, mime, path):
    head, _, b64 = uri.partition(",")
    assert head == "data:%s;base64" % mime, head
    assert base64.b64decode(b64) == open(path, "rb").read(), path
data(gltf["buffers"][0]["uri"], "application/octet-stream", d + "/BoxTextured0.bin")
data(gltf["images"][0]["uri"], "image/png", d + "/CesiumLogoFlat.png")
assert src["format"] == "gltf" and "file" not in src
print("ok")
EOF
check client_gltf_posts_data_uris "$(python3 "$T/body_check.py" "$T/body.json" "$T/BoxTextured" 2>&1 | tail -n 1)" \
    bash -c "python3 '$T/body_check.py' '$T/body.json' '$T/BoxTextured' >/dev/null 2>&1"

# Refusals: the client's own, before any request (the server is a closed port).
dir="$T/bad/models"
mkdir -p "$dir"
cp "$A/BoxTextured-glTF/"* "$dir/"
echo secret >"$T/bad/outside.bin"
ln -s ../outside.bin "$dir/link.bin"
truncate -s 300M "$dir/huge.bin" # sparse: over the 256 MiB a file may have
ln -s "$T/bad" "$dir/up"
# refuse NAME POINTER URI-REPLACEMENT EXPECTED-PATTERN [images]
refuse() {
    local name=$1 ptr=$2 uri=$3 want=$4 what=${5:-buffers}
    if [ "$what" = images ]; then
        sed "s|\"CesiumLogoFlat.png\"|\"$uri\"|" "$A/BoxTextured-glTF/BoxTextured.gltf" >"$dir/$name.gltf"
    else
        sed "s|\"BoxTextured0.bin\"|\"$uri\"|" "$A/BoxTextured-glTF/BoxTextured.gltf" >"$dir/$name.gltf"
    fi
    scene "$dir" "$name.gltf"
    "$CLIENT" render "$dir/scene.json" -o "$T/bad/$name.png" -s http://127.0.0.1:9 --retries 0 \
        -q 2>"$T/bad/$name.err"
    local rc=$? first lines
    first=$(head -n 1 "$T/bad/$name.err")
    lines=$(wc -l <"$T/bad/$name.err")
    if [ $rc = 1 ] && [ "$lines" = 1 ] &&
        [[ $first == "rayd-client: error: $dir/$name.gltf: $ptr: "*$want* ]]; then
        pass "client_gltf_refuses_$name"
    else
        fail "client_gltf_refuses_$name" "exit $rc: $(cat "$T/bad/$name.err")"
    fi
}
refuse dotdot /buffers/0/uri ../outside.bin "\"../outside.bin\" has a '..' component"
refuse dotdot_encoded /buffers/0/uri %2e%2e/outside.bin "has a '..' component"
refuse absolute /buffers/0/uri "$T/bad/outside.bin" "is an absolute path"
refuse symlink /buffers/0/uri link.bin "\"link.bin\": it leads out of the .gltf's folder"
refuse dir_symlink /buffers/0/uri up/outside.bin "\"up/outside.bin\": it leads out"
refuse url /buffers/0/uri http://example.com/box.bin "is a URL"
refuse missing /buffers/0/uri gone.bin "\"gone.bin\": No such file or directory"
refuse missing_image /images/0/uri gone.png "\"gone.png\": No such file or directory" images
refuse folder /buffers/0/uri . "\".\": not a regular file"
refuse huge /buffers/0/uri huge.bin "\"huge.bin\": too large to send"

# thumbnails: a folder with a .gltf and its files, and the same model as .glb
start_rayd --threads 2
mkdir -p "$T/th/gltf" "$T/th/glb"
cp "$A/BoxTextured-glTF/"* "$T/th/gltf/"
cp "$A/BoxTextured-glTF-Binary/BoxTextured.glb" "$T/th/glb/"
"$CLIENT" thumbnails "$T/th/gltf" -o "$T/th/out1" --size 40 -s "$URL" 2>"$T/th/1.err"
rc1=$?
"$CLIENT" thumbnails "$T/th/glb" -o "$T/th/out2" --size 40 -s "$URL" 2>"$T/th/2.err"
check client_gltf_thumbnail_equals_glb "exit $rc1: $(cat "$T/th/1.err" "$T/th/2.err")" \
    bash -c "[ $rc1 = 0 ] && [ -s '$T/th/out1/BoxTextured.png' ] &&
        cmp -s '$T/th/out1/BoxTextured.png' '$T/th/out2/BoxTextured.png'"
rm "$T/th/gltf/BoxTextured0.bin"
"$CLIENT" thumbnails "$T/th/gltf" -o "$T/th/out3" --size 40 -s "$URL" 2>"$T/th/3.err"
rc=$?
check client_gltf_thumbnail_missing_bin "exit $rc: $(cat "$T/th/3.err")" \
    bash -c "[ $rc = 1 ] && grep -q 'BoxTextured.gltf: /buffers/0/uri: cannot read \"BoxTextured0.bin\"' '$T/th/3.err' &&
        [ ! -e '$T/th/out3/BoxTextured.png' ]"
stop_rayd
exit $((NFAIL > 0))
