#!/usr/bin/env bash
# frames_meshes.sh -- a frame-range job decodes and builds its mesh sources
# once.  Each frame is parsed again (a frame is a pure function of the
# scene's bytes and its number), but a mesh file is the same bytes every
# frame: a frame's parse takes the mesh built from a live scene
# (rayd_asset_cache, core/geom/mesh_share.c), as /metrics counts, and the
# frames are still byte for byte rayd-render --frame K's.  Before, a
# 1.3M-triangle PLY cost 0.25 s of decoding and building a frame, nearly
# all of a 640x360 frame's time.  And a file that changes between two
# jobs is another mesh: the next job sees the new triangles.
source "$(dirname "$0")/lib/common.sh"

A=$T/assets
mkdir -p "$A"
# grid N X: an N x N grid of quads as an ASCII PLY, its far corner at height X
grid() {
    python3 - "$1" "$2" >"$A/grid.ply" <<'PY'
import math, sys
n, top = int(sys.argv[1]), float(sys.argv[2])
print("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
      "property float z\nelement face %d\nproperty list uchar int vertex_indices\nend_header"
      % ((n + 1) ** 2, 2 * n * n))
for j in range(n + 1):
    for i in range(n + 1):
        x, z = 2.0 * i / n - 1, 2.0 * j / n - 1
        print("%.5f %.5f %.5f" % (x, 0.6 + 0.2 * math.sin(5 * x) * math.cos(4 * z)
                                  + (top if i == n and j == n else 0), z))
for j in range(n):
    for i in range(n):
        a = j * (n + 1) + i
        print("3 %d %d %d\n3 %d %d %d" % (a, a + 1, a + n + 2, a, a + n + 2, a + n + 1))
PY
}
grid 30 0
# lib/anim.json (frames 2-9) with the grid turning over the box
python3 - "$RAYD_ROOT/tests/integration/lib/anim.json" "$A/anim.json" <<'PY'
import json, sys
scene = json.load(open(sys.argv[1]))
scene["objects"].append({"type": "mesh", "source": {"file": "grid.ply"},
                         "material": {"color": [0.2, 0.5, 0.9]},
                         "keyframes": [{"frame": 2, "rotate": [0, 0, 0]},
                                       {"frame": 9, "rotate": [0, 90, 0]}]})
json.dump(scene, open(sys.argv[2], "w"))
PY

start_rayd --threads 2 --asset-dir "$A"
shared0=$(metric rayd_scene_meshes_shared_total)
built0=$(metric rayd_scene_meshes_built_total)
code=$(post_json "/v1/jobs?frames=2-9" "$A/anim.json")
id=$(jfield "$T/body" id)
check job_made "$code $(head -c 200 "$T/body")" [ "$code" = 202 ]
wait_until 120 job_state_is "$id" succeeded
shared=$(($(metric rayd_scene_meshes_shared_total) - shared0))
built=$(($(metric rayd_scene_meshes_built_total) - built0))
# the job's own parse builds the grid; each of the 8 frames' parses finds it
check built_once "built $built, shared $shared over 8 frames" \
    eval '[ "$built" = 1 ] && [ "$shared" = 8 ]'
for k in 2 9; do
    code=$(req GET "/v1/jobs/$id/frames/$k.png")
    cp "$T/body" "$T/server-$k.png"
    timeout 120 "$RENDER" "$A/anim.json" --frame "$k" -o "$T/cli-$k.png" -q --threads 1
    check "frame_${k}_as_cli" "$code" eval '[ "$code" = 200 ] && cmp -s "$T/server-$k.png" "$T/cli-$k.png"'
done

# --- the file changed: the next job builds the new mesh ---------------------------------
grid 30 0.8
code=$(post_json "/v1/jobs?frames=9-9" "$A/anim.json")
id2=$(jfield "$T/body" id)
wait_until 120 job_state_is "$id2" succeeded
req GET "/v1/jobs/$id2/frames/9.png" >/dev/null
cp "$T/body" "$T/changed-9.png"
timeout 120 "$RENDER" "$A/anim.json" --frame 9 -o "$T/cli-changed-9.png" -q --threads 1
check changed_file_new_mesh "built $(($(metric rayd_scene_meshes_built_total) - built0))" \
    eval 'cmp -s "$T/changed-9.png" "$T/cli-changed-9.png" && ! cmp -s "$T/changed-9.png" "$T/server-9.png"'
stop_rayd
check rayd_exit "rayd exited with $RAYD_RC" [ "$RAYD_RC" = 0 ]
exit $((NFAIL > 0))
