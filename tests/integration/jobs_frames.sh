#!/usr/bin/env bash
# jobs_frames.sh -- frame-range jobs: POST /v1/jobs of an animated scene
# renders frames A..B, each its own render.  The job's JSON ("frames",
# "eta_s", "video_url"), its event stream (one "frame" event a frame), its
# frames (GET .../frames/{k}.png and .exr: 200, 409 frame_not_ready, 404
# frame_unknown, 400), frame k byte for byte rayd-render --frame K, the
# query's mistakes (400 naming frames or frame, --max-frames), a still
# scene's job unchanged, the list, DELETE, the video (an fps ffmpeg cannot
# take refused at POST, the slowest it takes made; ffmpeg failing is 500
# video_failed without the server's temp folder); a scene invalid at a later
# frame refused at POST, naming the frame, and a frame whose parse fails at
# every attempt failing its job at once; a frame refused for room
# waits and its job goes on.  The test gate holds the frames so the states
# in between are seen on any machine.
source "$(dirname "$0")/lib/common.sh"
source "$(dirname "$0")/lib/gone_scene.sh"

cp "$RAYD_ROOT/tests/integration/lib/anim.json" "$T/anim.json" # frames 2-9, 48x32
scene "$T/still.json" 32 32 1 spheres 3

start_rayd --threads 2 --test-gate 0 --max-frames 6

# ---- the query's mistakes: 400 naming the parameter ---------------------------------
bad_query() { # bad_query NAME QUERY PARAM TEXT: 400 bad_parameter naming PARAM, saying TEXT
    local code
    code=$(post_json "/v1/jobs?$2" "$T/anim.json")
    [ "$code" = 400 ] && err_is "$T/body" 400 bad_parameter &&
        grep -q "\"$3\"\|$3:\|'$3'\|$3 " "$T/body" && grep -q -- "$4" "$T/body"
}
check range_reversed "$(cat "$T/body" 2>/dev/null)" bad_query reversed "frames=6-3" frames "after the last"
check range_malformed "$(cat "$T/body")" bad_query malformed "frames=3to6" frames "must be A-B"
check range_malformed_one "$(cat "$T/body")" bad_query malformed1 "frames=x" frames "or one (frames=5)"
# frames=K: frame K alone, as rayd-render --frames K
code=$(post_json "/v1/jobs?frames=4" "$T/anim.json")
check range_one_frame "$code $(cat "$T/body")" eval \
    '[ "$code" = 202 ] && [ "$(json "$T/body" "(j[\"frames\"][\"first\"], j[\"frames\"][\"last\"])")" = "(4, 4)" ]'
req DELETE "/v1/jobs/$(jfield "$T/body" id)" >/dev/null
check range_outside "$(cat "$T/body")" bad_query outside "frames=1-4" frames "frames 2-9"
check range_frame_outside "$(cat "$T/body")" bad_query frame_out "frame=10" frame "frames 2-9"
check range_frame_malformed "$(cat "$T/body")" bad_query frame_bad "frame=0x3" frame "frame number"
check range_both "$(cat "$T/body")" bad_query both "frames=2-3&frame=4" frame "not both"
check range_twice "$(cat "$T/body")" bad_query twice "frames=2-3&frames=4-5" frames "more than once"
check range_over_cap "$(cat "$T/body")" bad_query cap "frames=2-9" frames "max-frames"
# the whole animation, no parameter given: none named, the animation's frames said
whole_over_cap() {
    [ "$(post_json /v1/jobs "$T/anim.json")" = 400 ] && err_is "$T/body" 400 bad_parameter &&
        grep -q '"path":"/animation"' "$T/body" && ! grep -q '"parameter"' "$T/body" &&
        grep -q "animation has 8 frames, more than the 6 .*frames=A-B" "$T/body"
}
check range_whole_over_cap "$(cat "$T/body")" whole_over_cap
check range_progressive "$(cat "$T/body")" bad_query prog "frames=2-3&progressive=1" progressive \
    "not progressive"
# the progressive job's options are refused too, never taken and dropped
for p in pass_step=2 time_budget=5 noise_target=0.1; do
    check "range_${p%%=*}" "$(cat "$T/body")" bad_query "${p%%=*}" "frames=2-3&$p" "${p%%=*}" \
        "not progressive"
done
code=$(post_json "/v1/jobs?frames=0-1" "$T/still.json")
check still_with_frames "$code $(cat "$T/body")" eval '[ "$code" = 400 ] && grep -q "no animation block" "$T/body"'

# ---- a still scene's job is as before ----------------------------------------------
code=$(post_json /v1/jobs "$T/still.json")
still=$(jfield "$T/body" id)
check still_job_unchanged "$code $(cat "$T/body")" eval \
    '[ "$code" = 202 ] && grep -q "\"image_url\"" "$T/body" && ! grep -q "\"frames\"" "$T/body"'

# ---- held at the gate: queued frames ------------------------------------------------
code=$(post_json "/v1/jobs?frames=3-6&format=exr&priority=high" "$T/anim.json")
id=$(jfield "$T/body" id)
check post_202 "$code $(cat "$T/body")" eval '[ "$code" = 202 ] && [ -n "$id" ] &&
    [ "$(header Location)" = "/v1/jobs/$id" ] && [ -n "$(header X-Rayd-Estimated-Rays)" ]'
check post_frames_object "$(cat "$T/body")" eval "[ \"\$(json \"\$T/body\" 'j[\"frames\"]')\" = \
\"{'first': 3, 'last': 6, 'total': 4, 'done': 0, 'running': 0, 'queued': 4, 'failed': 0, 'latest': None, 'url': '/v1/jobs/$id/frames/{k}.png', 'exr_url': '/v1/jobs/$id/frames/{k}.exr'}\" ]"
check post_no_image_url "$(cat "$T/body")" eval '! grep -q "\"image_url\"" "$T/body" &&
    [ "$(json "$T/body" "j[\"eta_s\"]")" = None ] && ! grep -q video_url "$T/body"'
req GET "/v1/jobs/$id/frames/4.png" >/dev/null
check frame_not_ready "$(cat "$T/body")" eval 'err_is "$T/body" 409 frame_not_ready &&
    [ "$(json "$T/body" "j[\"error\"][\"state\"]")" = queued ]'
code=$(req GET "/v1/jobs/$id/frames/7.png")
check frame_unknown "$code $(cat "$T/body")" eval 'err_is "$T/body" 404 frame_unknown && grep -q "3-6" "$T/body"'
code=$(req GET "/v1/jobs/$id/frames/99999999999.png") # well formed, past any frame: not in the job
check frame_unknown_past_any "$code $(cat "$T/body")" eval 'err_is "$T/body" 404 frame_unknown && grep -q "3-6" "$T/body"'
for bad in x.png 4.gif 4 -.png 1e3.png 9999999999999999999.png 04.png -0.png +4.png; do
    code=$(req GET "/v1/jobs/$id/frames/$bad")
    check "frame_malformed_$bad" "$code $(cat "$T/body")" err_is "$T/body" 400 bad_frame
done
code=$(req GET "/v1/jobs/0123456789abcdef0123456789abcdef/frames/4.png")
check frame_job_unknown "$code" err_is "$T/body" 404 job_unknown
code=$(req GET "/v1/jobs/$still/frames/0.png")
check frame_of_still_job "$code $(cat "$T/body")" err_is "$T/body" 404 frame_unknown
code=$(req GET "/v1/jobs/$still/video.mp4")
check video_of_still_job "$code $(cat "$T/body")" eval 'err_is "$T/body" 404 frame_unknown && grep -q "no video" "$T/body"'
code=$(req GET "/v1/jobs/$id/video.mp4")
check video_before_done "$code $(cat "$T/body") Retry-After '$(header Retry-After)'" eval \
    'err_is "$T/body" 409 frames_not_done && [ "$(header Retry-After)" = 1 ]'
code=$(req GET "/v1/jobs/$id/image.png")
check image_png_of_frames "$code $(cat "$T/body")" err_is "$T/body" 409 frame_range_job
code=$(req POST "/v1/jobs/$id/stop")
check stop_of_frames "$code" err_is "$T/body" 409 not_progressive

# ---- the list holds it, with its frames ----------------------------------------------
req GET /v1/jobs >/dev/null
check list_has_frames "$(head -c 300 "$T/body")" eval "[ \"\$(json \"\$T/body\" '[x[\"frames\"][\"total\"] for x in j[\"jobs\"] if x[\"id\"] == \"$id\"]')\" = '[4]' ]"
check list_newest_first "$(head -c 300 "$T/body")" eval "[ \"\$(json \"\$T/body\" '[x[\"id\"] for x in j[\"jobs\"]][:2]')\" = \"['$id', '$still']\" ]"
req GET "/v1/jobs?limit=1" >/dev/null
after=$(json "$T/body" 'j["next_after"]')
req GET "/v1/jobs?limit=1&after=$after" >/dev/null
check list_pages_across "$(cat "$T/body" | head -c 200)" eval "[ \"\$(json \"\$T/body\" 'j[\"jobs\"][0][\"id\"]')\" = '$still' ]"

# ---- the events: a frame event a frame, then done ------------------------------------
curl -s -N -m 120 "$URL/v1/jobs/$id/events" >"$T/events" &
ev=$!
PIDS+=("$ev")
gate open
wait_until 120 job_state_is "$id" succeeded
wait "$ev"
# its times, as a single job's: the wait for its first frame, its frames' renders and encodes
req GET "/v1/jobs/$id" >/dev/null
check job_times "$(cat "$T/body")" python3 -c 'import json, sys
j = json.load(open(sys.argv[1]))
sys.exit(0 if j["queue_ms"] > 0 and j["render_ms"] > 0 and j["encode_ms"] > 0 else 1)' "$T/body"
check events_frames "$(tr '\n' '|' <"$T/events")" eval \
    '[ "$(grep -c "^event: frame" "$T/events")" = 4 ] && [ "$(grep -c "^event: done" "$T/events")" = 1 ] &&
     grep -q "\"frames_done\":4,\"frames_total\":4" "$T/events" && grep -q "\"state\":\"succeeded\"" "$T/events"'
python3 - "$T/events" "$id" >"$T/events.check" <<'PY'
import json, sys
ks = []
for line in open(sys.argv[1]):
    if line.startswith("data:") and '"k"' in line:
        d = json.loads(line[5:])
        assert d["state"] == "done" and d["url"] == "/v1/jobs/%s/frames/%d.png" % (sys.argv[2], d["k"])
        ks.append(d["k"])
print(sorted(ks))
PY
check events_each_frame "$(cat "$T/events.check")" eval '[ "$(cat "$T/events.check")" = "[3, 4, 5, 6]" ]'

# ---- done: the JSON, each frame the bytes of rayd-render --frame K -------------------
req GET "/v1/jobs/$id" >/dev/null
check done_json "$(cat "$T/body")" eval "[ \"\$(json \"\$T/body\" '(j[\"frames\"][\"done\"], j[\"frames\"][\"queued\"], j[\"frames\"][\"running\"], j[\"eta_s\"], j[\"video_url\"], j[\"progress\"])')\" = \
\"(4, 0, 0, 0.0, '/v1/jobs/$id/video.mp4', 1.0)\" ]"
for k in 3 4 5 6; do
    code=$(req GET "/v1/jobs/$id/frames/$k.png")
    cp "$T/body" "$T/server-$k.png"
    timeout 120 "$RENDER" "$T/anim.json" --frame "$k" -o "$T/cli-$k.png" -q --threads 1
    check "frame_${k}_as_cli" "$code" eval '[ "$code" = 200 ] && cmp -s "$T/server-$k.png" "$T/cli-$k.png"'
done
code=$(req GET "/v1/jobs/$id/frames/5.exr")
cp "$T/body" "$T/server-5.exr"
timeout 120 "$RENDER" "$T/anim.json" --frame 5 -o "$T/cli-5.exr" -q
check frame_exr_as_cli "$code $(header Content-Type)" eval '[ "$code" = 200 ] && cmp -s "$T/server-5.exr" "$T/cli-5.exr"'
check frames_differ "frames 3 and 6 are the same image" eval '! cmp -s "$T/server-3.png" "$T/server-6.png"'

# ---- the video: H.264 MP4 of the four frames at the scene's fps ----------------------
video_ready() { [ "$(req GET "/v1/jobs/$id/video.mp4")" != 202 ]; }
wait_until 120 video_ready
code=$(req GET "/v1/jobs/$id/video.mp4")
cp "$T/body" "$T/shot.mp4"
check video_200 "$code $(header Content-Type)" eval '[ "$code" = 200 ] && [ "$(header Content-Type)" = video/mp4 ]'
probe=$(ffprobe -v error -select_streams v:0 -count_frames -show_entries \
    stream=codec_name,width,height,r_frame_rate,nb_read_frames,pix_fmt -of csv=p=0 "$T/shot.mp4" 2>&1)
check video_probe "$probe" eval '[ "$probe" = "h264,48,32,yuv420p,12/1,4" ]'

# ---- fps: a rate ffmpeg cannot take is refused at POST; the slowest it takes makes a video
sed 's/"fps": 12/"fps": FPS/' "$T/anim.json" >"$T/fps.tmpl"
for fps in 1e-300 1e-6 0.0009; do
    sed "s/FPS/$fps/" "$T/fps.tmpl" >"$T/fps.json"
    code=$(post_json "/v1/jobs?frames=2-3" "$T/fps.json")
    check "fps_${fps}_refused" "$code $(cat "$T/body")" eval \
        'err_is "$T/body" 422 invalid_scene /animation/fps && grep -q ">= 0.001" "$T/body"'
done
# video_of QUERY FILE: a job of FILE's frames (POST /v1/jobs?QUERY, its id in
# $vid) and its video asked for until it settles: the status in $code, $T/body
video_of() {
    post_json "/v1/jobs?$1" "$2" >/dev/null
    vid=$(jfield "$T/body" id)
    wait_until 120 job_state_is "$vid" succeeded
    video_settled() { [ "$(req GET "/v1/jobs/$vid/video.mp4")" != 202 ]; }
    wait_until 120 video_settled
    code=$(req GET "/v1/jobs/$vid/video.mp4")
}
sed "s/FPS/0.001/" "$T/fps.tmpl" >"$T/fps.json"
video_of "frames=2-3" "$T/fps.json"
cp "$T/body" "$T/slow.mp4"
probe=$(ffprobe -v error -select_streams v:0 -show_entries stream=r_frame_rate -of csv=p=0 "$T/slow.mp4" 2>&1)
check video_min_fps "$code $probe" eval '[ "$code" = 200 ] && [ "$probe" = 1/1000 ]'
# rayd-render's video is the server's, byte for byte: both run ffmpeg on one thread.  Left to
# itself ffmpeg takes a thread count from the machine's cores (past a small frame's size) and
# writes it into the video: rayd-render's 320 x 180 video differed from the server's from
# byte 611 on this 2-core machine
sed 's/"width": 48, "height": 32/"width": 320, "height": 180/' "$T/anim.json" >"$T/wide.json"
video_of "frames=3-4" "$T/wide.json"
cp "$T/body" "$T/wide.mp4"
timeout 120 "$RENDER" "$T/wide.json" --frames 3-4 --video "$T/cli.mp4" -q
check video_as_cli "$code, $(stat -c %s "$T/cli.mp4" "$T/wide.mp4" | tr '\n' ' ')bytes" eval \
    '[ "$code" = 200 ] && cmp -s "$T/cli.mp4" "$T/wide.mp4"'

# ---- no range: the whole animation; ?frame=K one frame ------------------------------
post_json "/v1/jobs?frame=9" "$T/anim.json" >/dev/null
one=$(jfield "$T/body" id)
check frame_one "$(cat "$T/body")" eval "[ \"\$(json \"\$T/body\" '(j[\"frames\"][\"first\"], j[\"frames\"][\"total\"])')\" = '(9, 1)' ]"
wait_until 120 job_state_is "$one" succeeded
req GET "/v1/jobs/$one/frames/9.png" >/dev/null
timeout 120 "$RENDER" "$T/anim.json" --frame 9 -o "$T/cli-9.png" -q
check frame_one_as_cli "frame 9 differs" cmp -s "$T/body" "$T/cli-9.png"
code=$(req GET "/v1/jobs/$one/frames/9.exr")
check frame_exr_not_kept "$code $(cat "$T/body")" err_is "$T/body" 409 not_exr
cat >"$T/short.json" <<'EOF'
{"animation": {"start": 2, "end": 5},
 "render": {"width": 16, "height": 16, "samples": 1},
 "camera": {"look_at": [0, 0.5, 0], "keyframes": [{"frame": 2, "position": [0, 1.5, 5]},
                                                   {"frame": 5, "position": [4, 2, 2]}]},
 "lights": [{"type": "point", "position": [4, 5, 4]}],
 "objects": [{"type": "plane", "material": {"color": [0.6, 0.6, 0.6]}}]}
EOF
post_json /v1/jobs "$T/short.json" >/dev/null
check whole_range "$(cat "$T/body")" eval "[ \"\$(json \"\$T/body\" '(j[\"frames\"][\"first\"], j[\"frames\"][\"last\"])')\" = '(2, 5)' ]"

# ---- DELETE cancels the frames still to come ------------------------------------------
gate 0
post_json "/v1/jobs?frames=2-7" "$T/anim.json" -H 'X-Tag: cancel' >/dev/null
cancel=$(jfield "$T/body" id)
code=$(req DELETE "/v1/jobs/$cancel")
check delete_frames "$code $(cat "$T/body")" eval '[ "$code" = 200 ] && [ "$(jfield "$T/body" state)" = canceled ]'
check delete_frames_none_queued "$(cat "$T/body")" eval '[ "$(json "$T/body" "j[\"frames\"][\"queued\"]")" = 0 ]'
gate open
code=$(req GET "/v1/jobs/$cancel/frames/2.png")
check frame_of_cancelled "$code $(cat "$T/body")" eval 'err_is "$T/body" 409 frame_not_ready && grep -q canceled "$T/body"'
# a frame its job will never render says so, with no Retry-After: before, "frame 2 is
# cancelled, not done: retry later" with Retry-After: 1, and a client polling for it as the
# docs do polled for ever; the video likewise
check frame_of_cancelled_final "$(cat "$T/headers" "$T/body" | tr '\r\n' '||')" eval \
    '[ -z "$(header Retry-After)" ] && grep -q "frame 2 was not rendered: its job was cancelled" "$T/body"'
code=$(req GET "/v1/jobs/$cancel/video.mp4")
check video_of_cancelled "$code $(cat "$T/body") Retry-After '$(header Retry-After)'" eval \
    'err_is "$T/body" 409 frames_not_done && [ -z "$(header Retry-After)" ] &&
    grep -q "the job was cancelled with 0 of 6 frames done: it has no video" "$T/body"'
# ---- a frame that keeps failing: tried 3 times, then the job fails naming it --------
curl -s -X POST "$URL/v1/test/gate?work=10" >/dev/null # every render made now runs out of rays
post_json "/v1/jobs?frame=8" "$T/anim.json" -H 'X-Tag: fail' >/dev/null
failing=$(jfield "$T/body" id)
wait_until 120 job_state_is "$failing" failed
req GET "/v1/jobs/$failing" >/dev/null
check failed_names_frame "$(cat "$T/body")" eval '[ "$(json "$T/body" "j[\"frames\"][\"failed\"]")" = 1 ] &&
    grep -q "frame 8 failed after 3 attempts" "$T/body"'
check failed_retried "$(grep -c "frame 8 failed" "$T/rayd.err") retries logged" eval \
    '[ "$(grep "job $failing: frame 8 failed" "$T/rayd.err" | grep -c "trying again")" = 2 ]'
curl -s -N -m 60 "$URL/v1/jobs/$failing/events" >"$T/fail.events"
check failed_event "$(tr '\n' '|' <"$T/fail.events")" eval \
    'grep -q "\"k\":8,\"state\":\"failed\"" "$T/fail.events" && grep -q "frame 8 failed after 3" "$T/fail.events"'
code=$(req GET "/v1/jobs/$failing/frames/8.png")
check failed_frame_409 "$code $(cat "$T/body")" eval 'err_is "$T/body" 409 frame_not_ready && grep -q failed "$T/body"'
curl -s -X POST "$URL/v1/test/gate?work=open" >/dev/null
check rayd_alive_before_restart "rayd died: $(tail -3 "$T/rayd.err")" kill -0 "$RAYD_PID"

# video_with DIR: a new rayd whose PATH is DIR (no ffmpeg, or the test's), and
# video_of of its frame 4
video_with() {
    stop_rayd
    RAYD_WRAP="env PATH=$1" start_rayd --threads 1
    video_of "frame=4" "$T/anim.json"
}

# ---- no ffmpeg: the video answers 503 no_ffmpeg, the frames as ever ------------------
mkdir -p "$T/nopath"
video_with "$T/nopath"
nof=$vid
check video_no_ffmpeg "$code $(cat "$T/body")" eval 'err_is "$T/body" 503 no_ffmpeg && grep -q "ffmpeg program" "$T/body"'
check frame_without_ffmpeg "frame 4 differs" eval '[ "$(req GET "/v1/jobs/$nof/frames/4.png")" = 200 ] && cmp -s "$T/body" "$T/cli-4.png"'
check rayd_alive "rayd died: $(tail -3 "$T/rayd.err")" kill -0 "$RAYD_PID"

# ---- a scene invalid at a later frame: refused at POST, naming the frame ----------
# A smooth curve takes the light's intensity below 0 at frames 11-19.  POST checks
# every frame's keyframed values (rayd_scene_check_frames: no object built), so
# nothing renders; before, the job failed after rendering frames 0-10.  A refusal
# takes no place under --max-jobs; the frames around the dip are jobs of their own.
stop_rayd
A=$T/assets
gone_scene "$A" "$T/gone.json" # and $A/tri.obj, the mesh it names
start_rayd --threads 1 --max-jobs 2 --asset-dir "$A" --test-gate 0
cat >"$T/dip.json" <<'JSON'
{"animation": {"end": 30}, "render": {"width": 4, "height": 4},
 "lights": [{"type": "point", "position": [0, 5, 5], "interpolation": "smooth",
             "keyframes": [{"frame": 0, "intensity": 1}, {"frame": 10, "intensity": 0},
                           {"frame": 20, "intensity": 0}, {"frame": 30, "intensity": 1}]}],
 "objects": [{"type": "sphere"}]}
JSON
for i in 1 2 3; do code=$(post_json /v1/jobs "$T/dip.json"); done
check invalid_frame_refused_at_post "$code $(cat "$T/body")" eval \
    '[ "$code" = 422 ] && err_is "$T/body" 422 invalid_scene /lights/0/keyframes &&
     grep -q "at frame 11, intensity: must be >= 0" "$T/body"'
code=$(post_json "/v1/jobs?frames=15-30" "$T/dip.json")
check invalid_frame_named_in_range "$code $(cat "$T/body")" eval \
    '[ "$code" = 422 ] && grep -q "at frame 15, intensity" "$T/body"'
code=$(post_json "/v1/jobs?frames=20-30" "$T/dip.json")
check invalid_frames_around_are_jobs "$code $(cat "$T/body")" eval '[ "$code" = 202 ]'
req DELETE "/v1/jobs/$(jfield "$T/body" id)" >/dev/null

# A frame whose parse fails at every attempt still fails its job at once, naming it:
# the mesh file is taken away while frame 0 is held at the gate (lib/gone_scene.sh).
code=$(post_json /v1/jobs "$T/gone.json")
gone=$(jfield "$T/body" id)
wait_until 30 gate_is held 1
rm "$A/tri.obj"
gate open
wait_until 60 job_state_is "$gone" failed
req GET "/v1/jobs/$gone" >/dev/null
check unreadable_frame_fails_at_once "$code $(cat "$T/body")" eval \
    '[ "$code" = 202 ] && grep -q "frame 1 failed after 1 attempt: " "$T/body" &&
     grep -q "tri.obj" "$T/body"'
check failed_job_logged "$(grep "job $gone" "$T/rayd.err")" \
    grep -q "job $gone: frame 1 failed after 1 attempt, and the job with it (.*tri.obj" "$T/rayd.err"
# A range whose check would cost more than its bound (its frames' parse work over 2e7
# rays' worth: here 301 frames of 2 MB of text) is not checked first, but frame by frame
# as it renders: the job is taken and fails at the frame, naming it.
python3 - "$T/dip.json" "$T/dip_long.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["animation"]["end"] = 300
for k in s["lights"][0]["keyframes"]:
    k["frame"] *= 10
text = json.dumps(s)
open(sys.argv[2], "w").write(text[:-1] + " " * (2 << 20) + "}")
PY
code=$(post_json "/v1/jobs?frames=100-300" "$T/dip_long.json")
long=$(jfield "$T/body" id)
wait_until 120 job_state_is "$long" failed
check costly_check_left_to_frames "$code $(head -c 400 "$T/body")" eval \
    '[ "$code" = 202 ] && grep -q "frame 1[01][0-9] failed after 1 attempt: at frame 1[01][0-9], intensity" "$T/body"'

code=$(post_json "/v1/jobs?frame=4" "$T/anim.json")
check failed_job_frees_max_jobs "$code $(cat "$T/body")" eval '[ "$code" = 202 ]'
check rayd_alive_after_invalid_frames "rayd died: $(tail -3 "$T/rayd.err")" kill -0 "$RAYD_PID"

# ---- a frame refused for room waits, uses no attempt, and its job goes on -----------
# One parse thread and a parse queue of one: frame 2 waits at the shut tile gate, then
# the parses are shut and a plain job's parse takes the queue's place.  Once the tiles
# open, frame 3's parse is refused (parse queue full): it waits, and when the parses
# open again the watcher starts the job again.
stop_rayd
start_rayd --threads 1 --parse-threads 1 --parse-queue 1 --test-gate 0
post_json "/v1/jobs?frames=2-4" "$T/anim.json" >/dev/null
roomy=$(jfield "$T/body" id)
curl -s -m 30 -X POST -o /dev/null "$URL/v1/test/gate?parses=0"
scene "$T/still2.json" 32 32 1 spheres 4
(curl -s -m 120 -o "$T/held.body" -X POST -H 'Content-Type: application/json' \
    --data-binary @"$T/still2.json" "$URL/v1/jobs") &
PIDS+=($!)
held=$!
wait_until 60 gate_is parses_waiting 1
gate open
frame_waits() { grep -q "job $roomy: frame 3 waits (.*parse queue is full" "$T/rayd.err"; }
wait_until 60 frame_waits
check room_refusal_waits "log: $(grep "$roomy" "$T/rayd.err" | tail -2)" frame_waits
curl -s -m 30 -X POST -o /dev/null "$URL/v1/test/gate?parses=open"
wait "$held"
wait_until 120 job_state_is "$roomy" succeeded
check room_refused_job_succeeds "$(req GET "/v1/jobs/$roomy"; head -c 400 "$T/body")" \
    job_state_is "$roomy" succeeded
check room_refusal_no_attempt "$(grep "job $roomy: frame .* failed" "$T/rayd.err" | head -2)" \
    eval '! grep -q "job $roomy: frame .* failed" "$T/rayd.err"'
check room_held_job_accepted "$(head -c 200 "$T/held.body")" grep -q '"id"' "$T/held.body"

# ---- ffmpeg fails: 500 video_failed with its message, not the server's temp folder ----
mkdir -p "$T/badff"
cat >"$T/badff/ffmpeg" <<'EOF'
#!/bin/sh
for a; do case $a in */frame-*) echo "$a: Invalid argument" >&2 ;; esac; done
exit 1
EOF
chmod +x "$T/badff/ffmpeg"
video_with "$T/badff"
check video_failed_500 "$code $(cat "$T/body")" eval \
    'err_is "$T/body" 500 video_failed && grep -q "frame-%06d.png: Invalid argument" "$T/body"'
check video_failed_no_path "$(cat "$T/body")" eval '! grep -q "rayd-video-" "$T/body"'
check video_failed_logged "$(grep -i ffmpeg "$T/rayd.err" | tail -2)" eval \
    'grep -q "rayd-video-[^ ]*/frame-%06d.png: Invalid argument" "$T/rayd.err"'
check rayd_alive_after_video_failed "rayd died: $(tail -3 "$T/rayd.err")" kill -0 "$RAYD_PID"

# ---- a DELETE stops its frames' parses ---------------------------------------------
# The parse gate holds frame 2's parse in the queue while the job is deleted: the parse
# then starts with no one wanting its scene and stops at once, canceled, and its scene
# is not cached.  (The core's look at the flag in the middle of a parse, between its
# steps and inside each BVH build, is test_scene_cancel's.)  Before, the parse ran in
# full: a 15 KB glTF of 5M triangles burned 1.3 s of CPU after its job's DELETE.
# post_held RANGE: a job of RANGE, its id in $held_id, the parses shut after the POST's
# own two, so its first frame's parse waits in the queue
post_held() {
    curl -s -m 30 -X POST -o /dev/null "$URL/v1/test/gate?parses=0"
    (curl -s -m 120 -o "$T/post_held.body" -X POST -H 'Content-Type: application/json' \
        --data-binary @"$T/anim.json" "$URL/v1/jobs?frames=$1") &
    PIDS+=($!)
    local posting=$!
    wait_until 60 gate_is parses_waiting 1
    # the POST's own parse and its check of the frames' keyframed values
    curl -s -m 30 -X POST -o /dev/null "$URL/v1/test/gate?parses=2"
    wait "$posting"
    held_id=$(jfield "$T/post_held.body" id)
    wait_until 60 gate_is parses_queued 1 # its first frame's
}
stop_rayd
start_rayd --threads 1 --test-gate open
post_held 2-4
gj=$held_id
entries=$(metric rayd_cache_entries)
req DELETE "/v1/jobs/$gj" >/dev/null
curl -s -m 30 -X POST -o /dev/null "$URL/v1/test/gate?parses=open"
parses_idle() { gate_is parses_queued 0 && gate_is parses_running 0; }
wait_until 60 parses_idle
check delete_stops_frame_parse "canceled $(metric rayd_scene_parses_canceled_total)" \
    metric_is rayd_scene_parses_canceled_total 1
check canceled_parse_not_cached "entries $entries -> $(metric rayd_cache_entries)" \
    metric_is rayd_cache_entries "$entries"
check deleted_job_canceled "$(req GET "/v1/jobs/$gj"; head -c 300 "$T/body")" \
    job_state_is "$gj" canceled
# A second job of the same frames posted while the deleted one's parse is still queued
# joins it: the parse is wanted again and goes on (it answered the new job's frame
# "the parse was canceled", and that job failed).  One parse is let through for the
# POST's check of its frames, which goes before the frames' parses.
post_held 2-3
gone=$held_id
req DELETE "/v1/jobs/$gone" >/dev/null
(curl -s -m 60 -o "$T/again.body" -X POST -H 'Content-Type: application/json' \
    --data-binary @"$T/anim.json" "$URL/v1/jobs?frames=2-3") &
PIDS+=($!)
posting=$!
wait_until 60 gate_is parses_waiting 2 # the deleted job's frame 3, the POST's check
curl -s -m 30 -X POST -o /dev/null "$URL/v1/test/gate?parses=1"
wait "$posting"
again=$(jfield "$T/again.body" id)
curl -s -m 30 -X POST -o /dev/null "$URL/v1/test/gate?parses=open"
wait_until 120 eval 'job_state_is "$again" succeeded || job_state_is "$again" failed'
check rejoined_parse_goes_on "$(req GET "/v1/jobs/$again"; head -c 400 "$T/body")" \
    job_state_is "$again" succeeded

# ---- a stop mid-video: its ffmpeg killed, its folder removed ------------------------
# The test's ffmpeg writes its PID and sleeps, so the video is being made when SIGTERM
# comes.  Before, the video thread was left to the process's exit: ffmpeg outlived rayd
# and wrote its out.mp4 into a folder of frames nobody removed, one a restart.  A server
# killed outright cannot clean up: its folders carry its PID, and the next server's start
# removes those whose PID no longer runs (a live one's, and one without a PID, stay).
mkdir -p "$T/slowff" "$T/vtmp"
cat >"$T/slowff/ffmpeg" <<EOF
#!/bin/sh
echo "\$@" >"$T/slowff.args"
echo \$\$ >"$T/slowff.pid"
exec /bin/sleep 120
EOF
chmod +x "$T/slowff/ffmpeg"
stop_rayd
RAYD_WRAP="env PATH=$T/slowff TMPDIR=$T/vtmp" start_rayd --threads 1
post_json "/v1/jobs?frames=2-4" "$T/anim.json" >/dev/null
slow=$(jfield "$T/body" id)
wait_until 120 job_state_is "$slow" succeeded
code=$(req GET "/v1/jobs/$slow/video.mp4")
wait_until 60 test -s "$T/slowff.pid"
ffpid=$(cat "$T/slowff.pid")
# one core beside the workers: left to choose, ffmpeg took every core
check video_ffmpeg_one_thread "$(cat "$T/slowff.args")" grep -q -- "-threads 1 -c:v libx264" "$T/slowff.args"
vdirs() { find "$T/vtmp" -maxdepth 1 -name 'rayd-video-*' | wc -l; }
check video_folder_named_by_pid "$(ls "$T/vtmp")" eval \
    '[ -d "$(echo "$T"/vtmp/rayd-video-"$RAYD_PID"-??????)" ]'
stop_rayd
ff_gone() { ! kill -0 "$ffpid" 2>/dev/null; }
wait_until 10 ff_gone
check stop_kills_ffmpeg "ffmpeg $ffpid: $(ps -o pid=,stat=,args= -p "${ffpid:-1}")" ff_gone
check stop_removes_video_folder "$(ls -R "$T/vtmp" | head -8)" eval '[ "$(vdirs)" = 0 ]'
check stop_mid_video_rc "rc $RAYD_RC" eval '[ "$RAYD_RC" = 0 ]'
kill "$ffpid" 2>/dev/null # only if the check above failed: the test's own process
sh -c 'exit 0' &
dead=$!
wait "$dead"
mkdir -p "$T/vtmp/rayd-video-$dead-abcdef" "$T/vtmp/rayd-video-$$-abcdef" "$T/vtmp/rayd-video-ABCDEF"
for d in "$T"/vtmp/rayd-video-*; do echo x >"$d/frame-000000.png"; done
RAYD_WRAP="env TMPDIR=$T/vtmp" start_rayd --threads 1
check sweep_dead_server_folder "$(ls "$T/vtmp")" eval '[ ! -e "$T/vtmp/rayd-video-$dead-abcdef" ]'
check sweep_keeps_live_and_unnamed "$(ls "$T/vtmp")" eval \
    '[ -f "$T/vtmp/rayd-video-$$-abcdef/frame-000000.png" ] && [ -d "$T/vtmp/rayd-video-ABCDEF" ]'
check sweep_logged "$(grep -i folder "$T/rayd.err" | tail -1)" \
    grep -q "removed 1 video folders" "$T/rayd.err"
exit $NFAIL
