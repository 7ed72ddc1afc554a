#!/usr/bin/env bash
# asset_dir.sh -- rayd --asset-dir DIR: a scene's mesh (OBJ, PLY), texture
# and environment map "file" names are read from inside DIR only.  A file inside renders
# the very bytes of the same mesh given inline; "..", an absolute path, a
# symbolic link leading out, a missing file, a directory, a FIFO and a
# server without --asset-dir are each refused with the file's JSON Pointer
# and a message saying what is wrong (422 invalid_scene, as every invalid
# scene), a file over the size limit with 413 too_large, and the server
# still answers afterwards.
source "$(dirname "$0")/lib/common.sh"

A=$T/assets
mkdir -p "$A/models"
printf 'v -1 0 0\nv 1 0 0\nv 0 1.5 0\nv 0 0.5 -1\nf 1 2 3\nf 1 4 2\nf 2 4 3\nf 3 4 1\n' >"$A/models/tet.obj"
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n-1 0 0\n1 0 0\n0 1.5 0\n3 0 1 2\n' >"$A/models/tri.ply"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >"$T/secret.obj"
ln -s "$T/secret.obj" "$A/models/abs_link.obj"         # absolute link, outside
ln -s ../../secret.obj "$A/models/rel_link.obj"         # relative link, outside
ln -s tet.obj "$A/models/same.obj"                      # relative link, inside
mkfifo "$A/models/fifo.obj"

# scene OUT SOURCE-JSON: a small frame of one mesh with that "source"
mesh_scene() {
    python3 - "$1" "$2" <<'PY'
import json, sys
s = {"render": {"width": 48, "height": 36}, "camera": {"position": [0, 1, 4], "look_at": [0, 0.5, 0]},
     "lights": [{"type": "point", "position": [3, 5, 4]}],
     "objects": [{"type": "mesh", "source": json.loads(sys.argv[2])}]}
open(sys.argv[1], "w").write(json.dumps(s))
PY
}
b64() { base64 -w0 "$1"; }
jstr() { python3 -c 'import json,sys; print(json.dumps(open(sys.argv[1]).read()))' "$1"; }

mesh_scene "$T/obj_file.json" '{"file": "models/tet.obj"}'
mesh_scene "$T/obj_link.json" '{"file": "models/same.obj"}'
mesh_scene "$T/obj_text.json" "{\"format\": \"obj\", \"text\": $(jstr "$A/models/tet.obj")}"
mesh_scene "$T/ply_file.json" '{"file": "./models/tri.ply"}'
mesh_scene "$T/ply_b64.json" "{\"format\": \"ply\", \"base64\": \"$(b64 "$A/models/tri.ply")\"}"

# --- without --asset-dir a file is refused, saying how to allow it ------------
start_rayd
code=$(post_json /v1/render "$T/obj_file.json")
check no_asset_dir_refused "status $code: $(head -c 300 "$T/body")" \
    err_is "$T/body" 422 invalid_scene /objects/0/source/file
check no_asset_dir_names_option "$(head -c 300 "$T/body")" grep -q -- '--asset-dir' "$T/body"
stop_rayd TERM

# --- a bad --asset-dir stops the start ----------------------------------------
"$RAYD" --port 0 --asset-dir "$T/nope" >"$T/bad.out" 2>"$T/bad.err" &
bad_pid=$!
PIDS+=("$bad_pid")
wait "$bad_pid"
rc=$?
check bad_asset_dir_exits "exit $rc, stderr '$(cat "$T/bad.err")'" \
    bash -c "[ $rc != 0 ] && grep -q 'asset-dir' '$T/bad.err' && [ ! -s '$T/bad.out' ]"

# --- with --asset-dir -----------------------------------------------------------
# given as a relative path: rayd keeps its real path
(cd "$T" && exec "$RAYD" --bind 127.0.0.1 --port 0 --asset-dir assets) >"$T/rayd.out" 2>"$T/rayd.err" &
RAYD_PID=$!
wait_until 30 bash -c "[ -s '$T/rayd.out' ]"
PORT=$(sed -n 's/.*:\([0-9]*\)$/\1/p' "$T/rayd.out" | head -n 1)
URL=http://127.0.0.1:$PORT
check started_with_asset_dir "stdout '$(cat "$T/rayd.out")'" [ -n "$PORT" ]

render_to() { # render_to SCENE OUT: POST /v1/render, the PNG into OUT
    local code; code=$(post_json /v1/render "$1")
    cp "$T/body" "$2" 2>/dev/null
    [ "$code" = 200 ] && is_png "$2"
}
check obj_file_renders "not a 200 PNG" render_to "$T/obj_file.json" "$T/obj_file.png"
check obj_text_renders "not a 200 PNG" render_to "$T/obj_text.json" "$T/obj_text.png"
check obj_file_equals_inline "the PNGs differ" cmp -s "$T/obj_file.png" "$T/obj_text.png"
check obj_link_inside_renders "not a 200 PNG" render_to "$T/obj_link.json" "$T/obj_link.png"
check obj_link_equals_inline "the PNGs differ" cmp -s "$T/obj_link.png" "$T/obj_text.png"
check ply_file_renders "not a 200 PNG" render_to "$T/ply_file.json" "$T/ply_file.png"
check ply_b64_renders "not a 200 PNG" render_to "$T/ply_b64.json" "$T/ply_b64.png"
check ply_file_equals_inline "the PNGs differ" cmp -s "$T/ply_file.png" "$T/ply_b64.png"
# the same scene through rayd-render (the file next to the scene) gives the same bytes
cp "$T/obj_file.json" "$A/scene.json"
"$RENDER" "$A/scene.json" -o "$T/cli.png" 2>"$T/cli.err"
check obj_file_equals_cli "rayd-render: $(cat "$T/cli.err")" cmp -s "$T/cli.png" "$T/obj_file.png"

# an environment map by "file" under DIR renders the bytes of the same map embedded
cp scenes/sky.hdr "$A/sky.hdr"
env_scene() {
    python3 - "$1" "$2" <<'PY'
import json, sys
s = {"render": {"width": 32, "height": 24, "samples": 4, "integrator": "path",
                "environment": json.loads(sys.argv[2])},
     "camera": {"position": [0, 1, 4], "look_at": [0, 0.5, 0]},
     "objects": [{"type": "sphere", "center": [0, 0.5, 0], "radius": 0.5}]}
open(sys.argv[1], "w").write(json.dumps(s))
PY
}
env_scene "$T/env_file.json" '{"file": "sky.hdr", "rotation": 45}'
env_scene "$T/env_b64.json" "{\"base64\": \"$(b64 "$A/sky.hdr")\", \"format\": \"hdr\", \"rotation\": 45}"
check env_file_renders "not a 200 PNG" render_to "$T/env_file.json" "$T/env_file.png"
check env_b64_renders "not a 200 PNG" render_to "$T/env_b64.json" "$T/env_b64.png"
check env_file_equals_inline "the PNGs differ" cmp -s "$T/env_file.png" "$T/env_b64.png"

# Each refusal: 422 invalid_scene at the file's JSON Pointer, the message
# holding what is wrong (one Python for all: its start-up is slow on a busy
# machine).
python3 - "$URL" <<'PY'
import json, sys, urllib.request, urllib.error
url = sys.argv[1] + "/v1/render"
def mesh(f):
    return {"render": {"width": 8, "height": 8},
            "objects": [{"type": "mesh", "source": {"format": "obj", "file": f}}]}
cases = [
    ("dotdot", mesh("../secret.obj"), "/objects/0/source/file", "'..'"),
    ("dotdot_inside", mesh("models/../../secret.obj"), "/objects/0/source/file", "'..'"),
    ("absolute", mesh("/etc/passwd"), "/objects/0/source/file", "not an absolute path"),
    ("abs_link", mesh("models/abs_link.obj"), "/objects/0/source/file", "leads outside the asset directory"),
    ("rel_link", mesh("models/rel_link.obj"), "/objects/0/source/file", "leads outside the asset directory"),
    ("missing", mesh("models/missing.obj"), "/objects/0/source/file",
     'cannot open "models/missing.obj": No such file or directory'),
    ("directory", mesh("models"), "/objects/0/source/file", "is not a regular file"),
    ("fifo", mesh("models/fifo.obj"), "/objects/0/source/file", "is not a regular file"),
    ("texture_dotdot", {"render": {"width": 8, "height": 8}, "objects": [{"type": "sphere",
     "material": {"texture": {"type": "image", "file": "../secret.png"}}}]},
     "/objects/0/material/texture/file", "'..'"),
    ("environment_dotdot", {"render": {"width": 8, "height": 8, "environment": {"file": "../sky.hdr"}}},
     "/render/environment/file", "'..'"),
    ("environment_not_hdr", {"render": {"width": 8, "height": 8, "environment": {"file": "models/tet.obj"}}},
     "/render/environment/file", "not a Radiance .hdr"),
]
for name, scene, path, part in cases:
    req = urllib.request.Request(url, json.dumps(scene).encode(), {"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=60) as r:
            status, body = r.status, r.read()
    except urllib.error.HTTPError as e:
        status, body = e.code, e.read()
    try:
        e = json.loads(body)["error"]
    except (ValueError, KeyError, TypeError):
        e = {}
    ok = status == 422 and e.get("status") == 422 and e.get("code") == "invalid_scene" and e.get("path") == path
    print("PASS %s_refused" % name if ok else "FAIL %s_refused: %d %r" % (name, status, body[:300]))
    ok = part in e.get("message", "")
    print("PASS %s_message" % name if ok else "FAIL %s_message: %r lacks %r" % (name, e.get("message"), part))
PY
[ $? = 0 ] || fail refusals "python exited with an error"

# a file over the scene size limit (256 MiB; sparse, so it costs no disk) is
# refused from its size, before a byte is read
truncate -s 257M "$A/models/huge.obj"
mesh_scene "$T/huge.json" '{"file": "models/huge.obj"}'
code=$(post_json /v1/render "$T/huge.json")
check huge_file_413 "status $code: $(head -c 300 "$T/body")" \
    err_is "$T/body" 413 too_large /objects/0/source/file
check huge_file_message "$(head -c 300 "$T/body")" grep -q 'over the limit of 268435456 bytes' "$T/body"

check still_healthy "healthz" [ "$(req GET /healthz)" = 200 ]
stop_rayd TERM
check exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
