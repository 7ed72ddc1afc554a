# tests/integration/lib/gone_scene.sh -- the frame-range job whose mesh file
# goes away: jobs_frames.sh and jobs_frames_durable.sh post it, hold frame 0
# at the test gate, remove the mesh and open the gate, so frame 1's parse
# fails at every attempt and fails the job.  Sourced after common.sh.
#
# gone_scene DIR SCENE: DIR/tri.obj, one triangle (DIR is the server's
# --asset-dir), and SCENE, four 4x4 frames of that mesh turning.
gone_scene() {
    mkdir -p "$1"
    printf 'v -1 0 -1\nv 1 0 -1\nv 0 1 0\nf 1 2 3\n' >"$1/tri.obj"
    cat >"$2" <<'JSON'
{"animation": {"end": 3}, "render": {"width": 4, "height": 4},
 "camera": {"position": [0, 0.5, 4], "look_at": [0, 0.5, 0]},
 "lights": [{"type": "point", "position": [0, 5, 5]}],
 "objects": [{"type": "mesh", "source": {"file": "tri.obj"},
              "keyframes": [{"frame": 0, "rotate": [0, 0, 0]}, {"frame": 3, "rotate": [0, 90, 0]}]}]}
JSON
}
