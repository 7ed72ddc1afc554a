#!/usr/bin/env bash
# frames_textures.sh -- a frame-range job decodes its image textures once.
# Each frame is parsed again (a frame is a pure function of the scene's
# bytes and its number), but the textures are the same bytes every frame:
# a frame's parse takes them decoded from a live scene (rayd_asset_cache,
# core/shade/texels.c), as /metrics counts, and the frames are still byte
# for byte rayd-render --frame K's, which decodes its own.  Before, a 2 KB
# scene of four 4096x4096 PNGs cost 1.2 s of decoding a frame, for every
# frame.  And a frame whose parse finds no room in the memory budget waits
# for it rather than failing its job.
source "$(dirname "$0")/lib/common.sh"

# textured ANIM SIDE: lib/anim.json (frames 2-9) with the plane and the box
# each given its own SIDE x SIDE PNG texture
textured() {
    python3 - "$RAYD_ROOT/tests/integration/lib/anim.json" "$1" "$2" <<'PY'
import base64, json, sys
sys.path.insert(0, sys.argv[1].rsplit("/", 1)[0])
from memory_helpers import png
scene = json.load(open(sys.argv[1]))
for obj, shade in zip(scene["objects"], (40, 200)):
    b64 = base64.b64encode(png(int(sys.argv[3]), shade)).decode()
    obj["material"]["texture"] = {"type": "image", "png_base64": b64}
json.dump(scene, open(sys.argv[2], "w"))
PY
}
textured "$T/anim.json" 64

start_rayd --threads 2
shared0=$(metric rayd_scene_images_shared_total)
decoded0=$(metric rayd_scene_images_decoded_total)
code=$(post_json "/v1/jobs?frames=2-9" "$T/anim.json")
id=$(jfield "$T/body" id)
check job_made "$code $(head -c 200 "$T/body")" [ "$code" = 202 ]
wait_until 120 job_state_is "$id" succeeded
shared=$(($(metric rayd_scene_images_shared_total) - shared0))
decoded=$(($(metric rayd_scene_images_decoded_total) - decoded0))
# the job's own parse decodes the two; each of the 8 frames' parses finds them
check decoded_once "decoded $decoded, shared $shared over 8 frames" \
    eval '[ "$decoded" = 2 ] && [ "$shared" = 16 ]'
for k in 2 7; do
    code=$(req GET "/v1/jobs/$id/frames/$k.png")
    cp "$T/body" "$T/server-$k.png"
    timeout 120 "$RENDER" "$T/anim.json" --frame "$k" -o "$T/cli-$k.png" -q --threads 1
    check "frame_${k}_as_cli" "$code" eval '[ "$code" = 200 ] && cmp -s "$T/server-$k.png" "$T/cli-$k.png"'
done
stop_rayd
check rayd_exit "rayd exited with $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- a frame with no room for its parse waits; it does not fail -------------------------
# Each frame's scene is 6.3 MB (two 512x512 textures); under a 10 MB budget
# a second frame's parse finds no room while the first is held at the gate
# (its own frame holds it).  It waits for the room, as a render refused for
# room does.  Before, it was tried again at once, and three attempts later
# the job failed out_of_memory.
textured "$T/big.json" 512
start_rayd --threads 2 --max-memory 10M --test-gate 0
code=$(post_json "/v1/jobs?frames=2-5" "$T/big.json")
id=$(jfield "$T/body" id)
frame_waits() { grep -q "job $id: frame [0-9]* waits" "$T/rayd.err"; }
wait_until 30 frame_waits
req GET "/v1/jobs/$id" >/dev/null
check room_frame_waits "$code $(head -c 400 "$T/body")" \
    eval '[ "$code" = 202 ] && frame_waits && [ "$(jfield "$T/body" state)" != failed ]'
gate open >/dev/null
job_ended() { job_state_is "$id" succeeded || [ "$(jfield "$T/body" state)" = failed ]; }
wait_until 120 job_ended
req GET "/v1/jobs/$id" >/dev/null
check room_job_succeeds "$(head -c 400 "$T/body")" [ "$(jfield "$T/body" state)" = succeeded ]
stop_rayd
check rayd_exit_budget "rayd exited with $RAYD_RC" [ "$RAYD_RC" = 0 ]
exit $((NFAIL > 0))
