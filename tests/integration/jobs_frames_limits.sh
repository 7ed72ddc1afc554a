#!/usr/bin/env bash
# jobs_frames_limits.sh -- frame-range jobs keep every limit while they
# run.  Memory: without --data-dir a finished frame counts in --max-memory
# as kind "frames", and the budget lets go of the oldest frames of the
# finished jobs first (their GET answers 410 result_evicted, naming
# --max-memory); a job whose own frames fill the budget fails; with --data-dir a frame on disk leaves memory and is
# served from its file.  --max-disk counts frames' files and evicts the
# oldest first (410 naming --max-disk), at start-up too.  A frame job's
# event stream is watched like a plain job's: a client that hangs up is
# noticed while every frame is held, and an idle stream gets keep-alives.
# --max-jobs and /readyz count unfinished frame-range jobs.  The test gate
# holds the frames, so nothing depends on timing.
source "$(dirname "$0")/lib/common.sh"

anim() { # anim FILE SIZE: a 4-frame animated scene, SIZE x SIZE
    cat >"$1" <<JSON
{"animation": {"start": 1, "end": 4, "fps": 10},
 "render": {"width": $2, "height": $2, "samples": 1},
 "camera": {"look_at": [0, 0.5, 0], "keyframes": [{"frame": 1, "position": [0, 1.5, 5]},
                                                   {"frame": 4, "position": [4, 2, 2]}]},
 "lights": [{"type": "point", "position": [4, 5, 4]}],
 "objects": [{"type": "plane", "material": {"color": [0.6, 0.6, 0.6]}},
             {"type": "sphere", "center": [0, 0.5, 0], "radius": 0.5,
              "material": {"color": [0.9, 0.3, 0.2]}}]}
JSON
}
anim "$T/big.json" 512
anim "$T/small.json" 48

# ---- memory, no --data-dir: frames count, the oldest finished go first --------------
LIMIT=16777216
start_rayd --max-memory 16M --threads 1
post_json '/v1/jobs?format=exr' "$T/big.json" >/dev/null
shot=$(jfield "$T/body" id)
wait_until 120 job_state_is "$shot" succeeded
frames=$(metric 'rayd_memory_bytes{kind="frames"}')
check frames_counted "frames kind: '$frames'" eval '[ -n "$frames" ] && [ "$frames" -gt 1000000 ]'
evicted=
for i in $(seq 1 12); do
    scene "$T/e$i.json" 512 512 1 spheres "$i"
    code=$(post_json '/v1/jobs?format=exr' "$T/e$i.json")
    [ "$code" = 202 ] || break
    wait_until 60 job_state_is "$(jfield "$T/body" id)" succeeded
    if [ "$(req GET "/v1/jobs/$shot/frames/1.png")" = 410 ]; then
        evicted=$i
        break
    fi
done
req GET "/v1/jobs/$shot/frames/1.exr" >/dev/null
check frame_evicted_410 "after ${i} jobs (last POST $code): $(head -c 300 "$T/body" | tr -cd '[:print:]')" eval \
    '[ -n "$evicted" ] && err_is "$T/body" 410 result_evicted && grep -q "max-memory" "$T/body"'
check frame_evicted_oldest_first "frame 4 of the shot: $(req GET "/v1/jobs/$shot/frames/4.png")" \
    eval '[ "$(req GET "/v1/jobs/$shot/frames/4.png")" = 200 ]'
check frames_within_budget "total $(memory_total)" eval '[ "$(memory_total)" -le "$LIMIT" ]'
check frames_job_still_there "$(req GET "/v1/jobs/$shot"; cat "$T/body")" job_state_is "$shot" succeeded
# then its video, once none of its frames is left: it held the budget for good before (a
# forced charge nothing let go), and other clients' renders got 503 memory_full
video_gone() { req GET "/v1/jobs/$shot" >/dev/null && ! grep -q video_url "$T/body"; }
wait_until 60 eval '[ "$(req GET "/v1/jobs/$shot/video.mp4")" = 200 ]'
for i in $(seq 13 40); do
    video_gone && break # (a GET of the video would keep it: the least used goes first)
    scene "$T/e$i.json" 512 512 1 spheres "$i"
    code=$(post_json '/v1/jobs?format=exr' "$T/e$i.json")
    [ "$code" = 202 ] || break
    wait_until 60 job_state_is "$(jfield "$T/body" id)" succeeded
done
req GET "/v1/jobs/$shot/video.mp4" >/dev/null
check video_evicted_410 "after job $i (last POST $code): $(head -c 300 "$T/body")" eval \
    'err_is "$T/body" 410 result_evicted && grep -q "video was let go.*max-memory" "$T/body"'
req GET "/v1/jobs/$shot" >/dev/null
check video_evicted_no_url "$(head -c 400 "$T/body")" eval '! grep -q video_url "$T/body"'
check video_evicted_within_budget "total $(memory_total)" eval '[ "$(memory_total)" -le "$LIMIT" ]'
stop_rayd

# ---- memory, --data-dir: a video let go is made again from the frames' files --------
start_rayd --max-memory 16M --threads 1 --data-dir "$T/d3"
post_json /v1/jobs "$T/big.json" >/dev/null
vshot=$(jfield "$T/body" id)
wait_until 120 job_state_is "$vshot" succeeded
wait_until 120 eval '[ "$(req GET "/v1/jobs/$vshot/video.mp4")" = 200 ]'
cp "$T/body" "$T/video_first.mp4"
video_let_go() { grep -q "job $vshot: video evicted" "$T/rayd.err"; }
for i in $(seq 41 70); do
    video_let_go && break
    scene "$T/e$i.json" 512 512 1 spheres "$i"
    post_json '/v1/jobs?format=exr' "$T/e$i.json" >/dev/null
    wait_until 60 job_state_is "$(jfield "$T/body" id)" succeeded
done
check video_let_go_on_disk "after job $i: $(grep -c evicted "$T/rayd.err") evictions logged" video_let_go
wait_until 120 eval '[ "$(req GET "/v1/jobs/$vshot/video.mp4")" = 200 ]'
check video_made_again "$(wc -c <"$T/body") bytes, first $(wc -c <"$T/video_first.mp4")" \
    cmp -s "$T/body" "$T/video_first.mp4"
# made again, it is the last kept, not the next to go: it was let go again at once, 62 times in
# 75 s of renders beside it, each time read back and encoded anew
for i in 71 72 73; do
    scene "$T/e$i.json" 512 512 1 spheres "$i"
    post_json '/v1/jobs?format=exr' "$T/e$i.json" >/dev/null
    wait_until 60 job_state_is "$(jfield "$T/body" id)" succeeded
done
lets=$(grep -c "job $vshot: video evicted" "$T/rayd.err")
check video_made_again_kept "let go $lets times; GET: $(req GET "/v1/jobs/$vshot/video.mp4")" \
    eval '[ "$lets" = 1 ] && [ "$(req GET "/v1/jobs/$vshot/video.mp4")" = 200 ]'
stop_rayd

# ---- memory, no --data-dir: a job whose own frames fill the budget fails --------------
# Its finished frames stay in memory until the job ends, so once they and the
# next frame need more than the whole budget that frame can never start: the
# job fails naming it and what holds the room.  Before, the frame waited for
# room (the log said "waits" each second) and the job ran for ever.
sed 's/"end": 4/"end": 12/' "$T/big.json" >"$T/twelve.json"
start_rayd --max-memory 16M --threads 1
post_json '/v1/jobs?format=exr' "$T/twelve.json" >/dev/null
filler=$(jfield "$T/body" id)
job_ended() { req GET "/v1/jobs/$filler" >/dev/null && [ "$(jfield "$T/body" state)" != running ] &&
    [ "$(jfield "$T/body" state)" != queued ]; }
wait_until 60 job_ended
check own_frames_fail_job "$(head -c 600 "$T/body")" eval '[ "$(jfield "$T/body" state)" = failed ] &&
    grep -q "finished frames hold [0-9]* bytes of the memory budget" "$T/body" && grep -q -- "--data-dir" "$T/body"'
stop_rayd

# ---- memory, --data-dir: a frame on disk leaves memory, served from its file --------
start_rayd --threads 1 --data-dir "$T/d1"
post_json '/v1/jobs?format=exr' "$T/small.json" >/dev/null
durable=$(jfield "$T/body" id)
wait_until 120 job_state_is "$durable" succeeded
wait_until 60 metric_is 'rayd_memory_bytes{kind="frames"}' 0
check frames_leave_memory "frames kind: $(metric 'rayd_memory_bytes{kind="frames"}')" \
    metric_is 'rayd_memory_bytes{kind="frames"}' 0
for k in 1 2 3 4; do
    timeout 120 "$RENDER" "$T/small.json" --frame "$k" -o "$T/cli-$k.png" -q --threads 1
    code=$(req GET "/v1/jobs/$durable/frames/$k.png")
    check "frame_${k}_from_file" "$code" eval '[ "$code" = 200 ] && cmp -s "$T/body" "$T/cli-$k.png"'
done
code=$(req GET "/v1/jobs/$durable/frames/2.exr")
# the file holds the EXR and, after it, its CRC-32 (15 bytes, store.c): the EXR alone is served
check frame_exr_from_file "$code" eval '[ "$code" = 200 ] &&
    cmp -s "$T/body" <(head -c -15 "$T/d1/results/$durable-2.exr")'
stop_rayd

# ---- --max-disk: frames' files count, the oldest go first ---------------------------
size() { stat -c %s "$1"; }
keep=$(($(size "$T/d1/results/$durable-3.png") + $(size "$T/d1/results/$durable-3.exr") +
    $(size "$T/d1/results/$durable-4.png") + $(size "$T/d1/results/$durable-4.exr")))
start_rayd --threads 1 --data-dir "$T/d2" --max-disk "$keep"
post_json '/v1/jobs?format=exr' "$T/small.json" >/dev/null
disk=$(jfield "$T/body" id)
wait_until 120 job_state_is "$disk" succeeded
frame_code() { req GET "/v1/jobs/$disk/frames/$1.png"; }
wait_until 30 eval '[ "$(frame_code 2)" = 410 ]'
codes="$(frame_code 1) $(frame_code 2) $(frame_code 3) $(frame_code 4)"
check disk_evicts_oldest_frames "$codes" eval '[ "$codes" = "410 410 200 200" ]'
req GET "/v1/jobs/$disk/frames/1.png" >/dev/null
check disk_evicted_410_names_why "$(cat "$T/body")" eval \
    'err_is "$T/body" 410 result_evicted && grep -q "max-disk" "$T/body"'
used=$(cat "$T"/d2/results/* | wc -c)
check disk_within_budget "$used of $keep" eval '[ "$used" -le "$keep" ] && [ ! -e "$T/d2/results/$disk-1.png" ]'
stop_rayd
start_rayd --threads 1 --data-dir "$T/d2" --max-disk "$keep"
codes="$(frame_code 1) $(frame_code 2) $(frame_code 3) $(frame_code 4)"
check disk_evicted_after_restart "$codes $(req GET "/v1/jobs/$disk"; cat "$T/body")" eval \
    '[ "$codes" = "410 410 200 200" ] && job_state_is "$disk" succeeded'
# the video is made again at start-up, and cannot be: its first frame is gone
wait_until 30 eval '[ "$(req GET "/v1/jobs/$disk/video.mp4")" != 202 ]'
req GET "/v1/jobs/$disk/video.mp4" >/dev/null
check disk_evicted_video_410 "$(cat "$T/body")" eval \
    'err_is "$T/body" 410 result_evicted && grep -q "frame 1 was let go .*--max-disk" "$T/body"'
req GET "/v1/jobs/$disk" >/dev/null
check disk_evicted_no_video_url "$(cat "$T/body")" eval '! grep -q video_url "$T/body"'
stop_rayd

# ---- the event stream: hang-ups noticed, keep-alives, with every frame held ---------
start_rayd --threads 1 --test-gate 0 --max-jobs 2
post_json /v1/jobs "$T/small.json" >/dev/null
held=$(jfield "$T/body" id)
curl -s -N -m 60 "$URL/v1/jobs/$held/events" >"$T/hang.events" &
hang=$!
PIDS+=("$hang")
curl -s -N -m 40 "$URL/v1/jobs/$held/events" >"$T/idle.events" &
idle=$!
PIDS+=("$idle")
wait_until 30 grep -q "^event: state" "$T/hang.events"
kill "$hang"
wait_until 30 grep -q "GET /v1/jobs/$held/events .*client_gone" "$T/rayd.err"
check stream_hangup_noticed "$(grep "/events" "$T/rayd.err" | tail -2)" \
    grep -q "GET /v1/jobs/$held/events .*client_gone" "$T/rayd.err"
wait_until 35 grep -q "^: keep-alive" "$T/idle.events"
check stream_keepalive "$(tr '\n' '|' <"$T/idle.events")" grep -q "^: keep-alive" "$T/idle.events"

# ---- --max-jobs and /readyz count unfinished frame-range jobs -----------------------
post_json /v1/jobs "$T/small.json" >/dev/null
req GET /readyz >/dev/null
check readyz_counts_frame_jobs "$(cat "$T/body")" eval \
    '[ "$(jfield "$T/body" jobs)" = 2 ] && grep -q "jobs_refused" "$T/body"'
scene "$T/still.json" 16 16 1 spheres 1
code=$(post_json /v1/jobs "$T/still.json")
check max_jobs_counts_frame_jobs "$code $(cat "$T/body")" eval '[ "$code" = 503 ]'
gate open
wait_until 120 job_state_is "$held" succeeded
code=$(post_json /v1/jobs "$T/still.json")
check max_jobs_room_after_end "$code $(cat "$T/body")" eval '[ "$code" = 202 ]'
# ---- a job's scene text counts in --max-memory while it runs, and goes when it ends --------
# A 1 MB body (a tiny animated scene and spaces) is a job that keeps its text for its
# frames' parses: held at the gate, 64 MB of budget takes a few dozen such jobs, then says
# 503 memory_full.  Once they end their texts are let go, and another is taken.  Before, 300
# jobs of a 4 MB body held 1.2 GB under a budget of 512 MB, all of it uncounted, for the ten
# minutes of --job-ttl after each had finished.
stop_rayd
start_rayd --threads 1 --max-memory 64M --test-gate 0
python3 - "$T/small.json" "$T/padded.json" <<'PY'
import sys
text = open(sys.argv[1]).read().rstrip()
open(sys.argv[2], "w").write(text[:-1] + " " * (1 << 20) + "}")
PY
codes=
for i in $(seq 1 80); do
    code=$(post_json "/v1/jobs?frames=1-1" "$T/padded.json")
    codes="$codes $code"
    [ "$code" = 202 ] || break
done
taken=$(grep -o 202 <<<"$codes" | wc -l)
frames_bytes=$(metric 'rayd_memory_bytes{kind="frames"}')
check text_in_budget "taken $taken: $codes; $(head -c 300 "$T/body")" eval \
    '[ "$code" = 503 ] && err_is "$T/body" 503 memory_full && [ "$taken" -ge 8 ] &&
     [ "$frames_bytes" -ge $((taken << 20)) ]'
gate open
all_ended() { [ "$(metric 'rayd_memory_bytes{kind="frames"}')" -lt $((taken * 200000)) ]; }
wait_until 120 all_ended
check text_let_go_at_end "frames $(metric 'rayd_memory_bytes{kind="frames"}') bytes for $taken jobs" all_ended
code=$(post_json "/v1/jobs?frames=1-1" "$T/padded.json")
check text_room_again "status $code: $(head -c 200 "$T/body")" [ "$code" = 202 ]
# ---- one client cannot fill --max-jobs: its last quarter is kept for the others -----------
# A frame-range job holds no place in the render queue until its frames start, so the
# queue's kept places never applied: twenty 1000-frame jobs of one client filled a
# --max-jobs of 20, and every other client's POST /v1/jobs got 503 for as long as their
# frames took.  Held at the gate, client A takes 6 of 8, B the rest.
stop_rayd
start_rayd --threads 1 --max-jobs 8 --client-header X-Client --test-gate 0
codes=
for i in 1 2 3 4 5 6 7; do codes="$codes $(post_json /v1/jobs "$T/small.json" -H 'X-Client: A')"; done
check jobs_share_kept "A: $codes; $(head -c 300 "$T/body")" eval \
    '[ "$codes" = " 202 202 202 202 202 202 503" ] && err_is "$T/body" 503 queue_full &&
     grep -q "kept for clients with few jobs unfinished" "$T/body" && [ -n "$(header Retry-After)" ]'
code=$(post_json /v1/jobs "$T/still.json" -H 'X-Client: A')
check jobs_share_plain_job_too "$code $(head -c 200 "$T/body")" [ "$code" = 503 ]
codes="$(post_json /v1/jobs "$T/small.json" -H 'X-Client: B') $(post_json /v1/jobs "$T/still.json" -H 'X-Client: B')"
check jobs_share_other_client "B: $codes" [ "$codes" = "202 202" ]
code=$(post_json /v1/jobs "$T/still.json" -H 'X-Client: C')
check jobs_share_cap_holds "$code $(head -c 200 "$T/body")" eval '[ "$code" = 503 ] &&
    grep -q "too many unfinished jobs" "$T/body"'
gate open
check rayd_alive "rayd died: $(tail -3 "$T/rayd.err")" kill -0 "$RAYD_PID"
exit $NFAIL
