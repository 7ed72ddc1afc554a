#!/usr/bin/env bash
# cluster_faults.sh -- rayd --redis when things break: a node killed while
# it holds items, Redis killed and started again on its AOF, a node of
# another version, tiles (PNG and EXR) missing or corrupt in Redis, a
# node killed while it makes a frame range's video.
#
# A real redis-server on a free loopback port (lib/redis.sh, an AOF written
# at every command) and rayd nodes with --redis-claim-ms 1500 and the test
# gate (--test-gate 0: a node takes items up to its workers and holds them,
# unrendered, until POST /v1/test/gate lets tiles start), so each fault
# hits work in flight on any machine, with no sleep deciding it.  Each job's
# image must still be byte for byte rayd-render's.  Every process is
# stopped by its PID.
# rayd-test: long (a kill -9 of a node, of Redis and a stalled Redis, each waited out)
source "$(dirname "$0")/lib/common.sh"
source "$(dirname "$0")/lib/redis.sh"

SCENE=$RAYD_ROOT/scenes/spheres.json
JSON=(-H 'Content-Type: application/json')
"$RENDER" "$SCENE" -o "$T/ref.png" 2>/dev/null && "$RENDER" "$SCENE" -o "$T/ref.exr" 2>/dev/null ||
    { echo "FAIL setup: rayd-render"; exit 1; }
VERSION=$("$RAYD" --version | awk '{print $2}')

gate_node() { curl -s -m 30 -X POST -o /dev/null "${NODE_URL[$1]}/v1/test/gate?tiles=$2"; }
post_job() { # NODE [QUERY]: the new job's id
    curl -s -m 30 "${JSON[@]}" --data-binary @"$SCENE" "${NODE_URL[$1]}/v1/jobs?${2:-}" |
        python3 -c 'import json,sys; print(json.load(sys.stdin).get("id", ""))'
}
succeeded() { [ "$(job_state "${NODE_URL[$1]}" "$2")" = succeeded ]; }
same_image() { # NODE ID NAME
    curl -s -m 30 -o "$T/$3.png" "${NODE_URL[$1]}/v1/jobs/$2/image.png"
    cmp -s "$T/$3.png" "$T/ref.png"
}
holds() { [ "$(metric "$1" rayd_cluster_node_items_in_flight)" -ge "$2" ]; }
NODE_ARGS=(--threads 2 --cluster-tile 64 --redis-claim-ms 1500 --test-gate 0)

start_redis
for i in 1 2 3; do start_node $i "${NODE_ARGS[@]}" --redis "$REDIS_URL"; done

# --- kill -9 a node while it holds items ----------------------------------------------------
ID=$(post_job 1)
wait_until 30 holds 1 2
check node_holds_items "node 1 holds $(metric 1 rayd_cluster_node_items_in_flight) items" holds 1 2
kill -KILL "${NODE_PID[1]}"
wait "${NODE_PID[1]}" 2>/dev/null
for i in 2 3; do gate_node $i open; done
wait_until 50 succeeded 2 "$ID"
check killed_node_job_finishes "state: $(job_state "${NODE_URL[2]}" "$ID")" succeeded 2 "$ID"
check killed_node_byte_identical "the image differs from rayd-render's" same_image 3 "$ID" kill
rec=$(($(metric 2 rayd_cluster_items_reclaimed_total) + $(metric 3 rayd_cluster_items_reclaimed_total)))
check reclaimed_counted "rayd_cluster_items_reclaimed_total of nodes 2 and 3: $rec" [ "$rec" -ge 2 ]
check reclaim_logged "no take-over in the logs" grep -q "took over item" "$T/node2.err" "$T/node3.err"

# --- kill -9 a node between a tile's write and its ack: the duplicate changes nothing ------------
for i in 2 3; do gate_node $i 0; done
RAYD_TEST_CLUSTER_STALL=1 start_node 8 "${NODE_ARGS[@]}" --redis "$REDIS_URL"
WID=$(post_job 8)
gate_node 8 1
wait_until 30 grep -q "RAYD_TEST_CLUSTER_STALL: the puller stops" "$T/node8.err"
kill -KILL "${NODE_PID[8]}"
wait "${NODE_PID[8]}" 2>/dev/null
for i in 2 3; do gate_node $i open; done
wait_until 50 succeeded 2 "$WID"
check killed_in_write_job_finishes "state: $(job_state "${NODE_URL[2]}" "$WID")" succeeded 2 "$WID"
check killed_in_write_byte_identical "the image differs from rayd-render's" same_image 3 "$WID" write
check killed_in_write_counted_once "$(curl -s "${NODE_URL[3]}/v1/jobs/$WID" | head -c 200)" bash -c "curl -s '${NODE_URL[3]}/v1/jobs/$WID' | grep -q '\"tiles_done\":80,\"tiles_total\":80'"

# --- Redis down, then back on its AOF -----------------------------------------------------------
for i in 2 3; do gate_node $i 0; done
ID2=$(post_job 2)
wait_until 30 bash -c "[ \$(curl -s '${NODE_URL[2]}/metrics' | awk '\$1 == \"rayd_cluster_node_items_in_flight\" {print \$2}') -ge 1 ]"
stop_redis
code=$(curl -s -D "$T/down.h" -o "$T/down.json" -w '%{http_code}' "${NODE_URL[3]}/v1/jobs/$ID2")
check redis_down_503 "GET gave $code: $(head -c 300 "$T/down.json")" bash -c "[ $code = 503 ] &&
    grep -q '\"code\":\"cluster_unavailable\"' '$T/down.json' && grep -q '127.0.0.1:$REDIS_PORT' '$T/down.json' &&
    grep -qi '^Retry-After: [0-9]' '$T/down.h'"
for route in "POST /v1/jobs" "GET /v1/jobs" "DELETE /v1/jobs/$ID2" "GET /v1/jobs/$ID2/image.png" "GET /v1/jobs/$ID2/events"; do
    code=$(curl -s -o /dev/null -w '%{http_code}' -X "${route%% *}" "${JSON[@]}" --data-binary @"$SCENE" "${NODE_URL[2]}${route#* }")
    [ "$code" = 503 ] || fail "redis_down_${route// /_}" "gave $code"
done
pass redis_down_every_job_route_503
gate_node 3 open
code=$(curl -s -o "$T/render.png" -w '%{http_code}' "${JSON[@]}" --data-binary @"$SCENE" "${NODE_URL[3]}/v1/render")
check redis_down_render_200 "POST /v1/render gave $code" bash -c "[ $code = 200 ] && cmp -s '$T/render.png' '$T/ref.png'"
wait_until 10 bash -c "curl -s '${NODE_URL[2]}/healthz' | grep -q '\"redis\":\"down\"'"
check redis_down_healthz "$(curl -s "${NODE_URL[2]}/healthz")" bash -c "curl -s '${NODE_URL[2]}/healthz' | grep -q '\"redis\":\"down\"'"
"$RAYD_BUILD/rayd-client" health --server "${NODE_URL[2]}" >"$T/health.out" 2>&1
rc=$?
check redis_down_client_health "exit $rc: $(cat "$T/health.out")" bash -c "[ $rc = 1 ] && grep -q 'cluster: redis DOWN at 127.0.0.1:$REDIS_PORT' '$T/health.out'"
check redis_down_metric "rayd_cluster_redis_up $(metric 2 rayd_cluster_redis_up)" [ "$(metric 2 rayd_cluster_redis_up)" = 0 ]
# said where an operator and a balancer look: a warning in the log (before, "info", and nothing
# at all when Redis was down from the start), and /readyz, still 200 for renders, says why jobs
# are refused
check redis_down_warned "$(grep -i redis "$T/node2.err" | tail -2)" \
    grep -q "warn cluster: Redis at 127.0.0.1:$REDIS_PORT is down" "$T/node2.err"
code=$(curl -s -o "$T/ready.json" -w '%{http_code}' "${NODE_URL[2]}/readyz")
check redis_down_readyz_says "$code $(cat "$T/ready.json")" bash -c "[ $code = 200 ] &&
    grep -q '\"jobs_refused\":\"the cluster.s Redis at 127.0.0.1:$REDIS_PORT is down' '$T/ready.json'"
restart_redis
gate_node 2 open
wait_until 50 succeeded 3 "$ID2"
check redis_back_job_finishes "state: $(job_state "${NODE_URL[3]}" "$ID2")" succeeded 3 "$ID2"
check redis_back_byte_identical "the image differs from rayd-render's" same_image 2 "$ID2" back
# the figures /metrics reads are the puller's, read at its next turn (a second at most): the job
# can end through the request thread's connection before node 3's puller has looked again
redis_up() { [ "$(metric 3 rayd_cluster_redis_up)" = 1 ]; }
wait_until 10 redis_up
check redis_back_up_metric "rayd_cluster_redis_up $(metric 3 rayd_cluster_redis_up)" redis_up

# --- Redis restarted while the nodes are idle: the first request after it is answered -----------
# (each node's connections still hold the old Redis's sockets; one is replaced before it is used)
stop_redis
restart_redis
for n in 2 3; do
    wait_until 20 bash -c "curl -s '${NODE_URL[$n]}/healthz' | grep -q '\"redis\":\"up\"'"
done
codes=""
for n in 2 3; do codes="$codes $(curl -s -o "$T/first.json" -w '%{http_code}' "${NODE_URL[$n]}/v1/jobs/$ID2")"; done
check redis_restarted_first_request "codes:$codes $(head -c 200 "$T/first.json")" [ "$codes" = " 200 200" ]

# --- Redis that stops answering (SIGSTOP): a timeout, never a hang -------------------------------
kill -STOP "$REDIS_PID"
code=$(curl -s -m 20 -o "$T/stall.json" -w '%{http_code}' "${NODE_URL[3]}/v1/jobs/$ID2")
check redis_stalled_503 "GET gave $code: $(head -c 300 "$T/stall.json")" bash -c "[ $code = 503 ] && grep -q cluster_unavailable '$T/stall.json'"
code=$(curl -s -m 20 -o /dev/null -w '%{http_code}' "${NODE_URL[3]}/healthz")
check redis_stalled_healthz "/healthz gave $code" [ "$code" = 200 ]
kill -CONT "$REDIS_PID"
wait_until 20 succeeded 2 "$ID2"
check redis_resumed "state after SIGCONT: $(job_state "${NODE_URL[2]}" "$ID2")" succeeded 2 "$ID2"

# --- a node of another version ------------------------------------------------------------------
RAYD_TEST_VERSION=9.9.9-test start_node 4 "${NODE_ARGS[@]}" --redis "$REDIS_URL"
OID=$(post_job 4)
wait_until 30 holds 4 2
wait_until 10 bash -c "curl -s '${NODE_URL[2]}/healthz' | grep -q '9.9.9-test'"
check other_version_healthz "$(curl -s "${NODE_URL[2]}/healthz")" bash -c "curl -s '${NODE_URL[2]}/healthz' | grep -q 'rayd 9.9.9-test: [0-9]* items wait for nodes of that version'"
check other_version_logged "node 2's log does not say it" grep -q "takes no item of another version: rayd 9.9.9-test" "$T/node2.err"
consumers=$(rcli xinfo consumers rayd:items:9.9.9-test render | awk 'NR % 6 == 2' | tr '\n' ' ')
check other_version_not_taken "consumers of the 9.9.9-test items: $consumers" [ "$(echo $consumers | wc -w)" = 1 ]
check other_version_own_stream "items of 9.9.9-test: $(rcli xlen rayd:items:9.9.9-test)" [ "$(rcli xlen rayd:items:9.9.9-test)" -gt 2 ]
check other_version_job_waits "state: $(job_state "${NODE_URL[3]}" "$OID")" [ "$(job_state "${NODE_URL[3]}" "$OID")" = queued ]
# an event stream of that waiting job, closed by its client: the node lets go of it
curl -s -N -m 1 "${NODE_URL[2]}/v1/jobs/$OID/events" >"$T/oid_events.txt"
check events_of_waiting_job "$(head -c 200 "$T/oid_events.txt")" grep -q '"state":"queued"' "$T/oid_events.txt"
# ... and a keep-alive once it has been silent for 15 s (the gate's clock jumps 20 s)
curl -s -N -m 4 "${NODE_URL[3]}/v1/jobs/$OID/events" >"$T/oid_ping.txt" &
ping_curl=$!
wait_until 10 grep -q '"state":"queued"' "$T/oid_ping.txt"
curl -s -m 10 -X POST -o /dev/null "${NODE_URL[3]}/v1/test/gate?clock=20"
wait "$ping_curl"
check events_keep_alive "$(tail -c 200 "$T/oid_ping.txt")" grep -q '^: keep-alive$' "$T/oid_ping.txt"
unsuspended() { [ "$(metric 2 rayd_http_suspended)" = 0 ]; }
wait_until 10 unsuspended
check events_client_gone "node 2 still holds $(metric 2 rayd_http_suspended) suspended connections" unsuspended
kill -KILL "${NODE_PID[4]}"

# --- tiles missing or corrupt in Redis (a job keeping an EXR: its tiles' EXRs too) -------------
RAYD_TEST_CLUSTER_TILE=corrupt start_node 5 "${NODE_ARGS[@]}" --redis "$REDIS_URL"
RAYD_TEST_CLUSTER_TILE=missing start_node 6 "${NODE_ARGS[@]}" --redis "$REDIS_URL"
for i in 2 3; do gate_node $i 0; done
BID=$(post_job 5 format=exr)
both_hold() { holds 5 1 && holds 6 1; }
wait_until 30 both_hold
for i in 2 3 5 6; do gate_node $i open; done
wait_until 50 succeeded 5 "$BID"
check bad_tiles_job_finishes "state: $(job_state "${NODE_URL[5]}" "$BID")" succeeded 5 "$BID"
check bad_tiles_byte_identical "the image differs from rayd-render's" same_image 6 "$BID" bad
curl -s -m 30 -o "$T/bad.exr" "${NODE_URL[2]}/v1/jobs/$BID/image.exr"
check bad_tiles_exr_byte_identical "the EXR differs from rayd-render's" cmp -s "$T/bad.exr" "$T/ref.exr"
check bad_tiles_rerendered "no re-render in the logs" bash -c "cat '$T'/node*.err | grep -q 'missing or corrupt in Redis'"

# --- a tile that fails on the node that took it, over that node's own limits -----------------
# Nodes of a version of their own (only they take these jobs), one thread each, and jobs of one
# 64x64 tile.  Node 16 holds a tile of a first job behind its gate, so node 17 (--max-work 1000:
# every tile is over it) takes the second job's tile: it fails there and is left pending for
# another node.  Node 17 killed, node 16, its gate open, takes it over and renders it.  Then, node
# 16 full again, node 18 (--max-work 1000 too) is the only node with room: it fails the third
# job's tile once and leaves it for as long as node 16, busy, has not tried it; node 16, its
# gate open, renders it.  Before, node 18 tried it twice more and failed the job.
small() { # N: a 64x64 scene of its own (seed N: no cache answers it from another job's tile)
    python3 - "$SCENE" "$T/small$1.json" "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
d["render"]["width"] = d["render"]["height"] = 64
d["render"]["seed"] = int(sys.argv[3])
json.dump(d, open(sys.argv[2], "w"))
PY
}
post_small() { # NODE N [QUERY]: the new job's id
    small "$2"
    curl -s -m 30 "${JSON[@]}" --data-binary @"$T/small$2.json" "${NODE_URL[$1]}/v1/jobs?${3:-}" |
        python3 -c 'import json,sys; print(json.load(sys.stdin).get("id", ""))'
}
LIM=(--threads 1 --cluster-tile 64 --redis-claim-ms 1500 --redis "$REDIS_URL")
RAYD_TEST_VERSION=9.9.7-limits start_node 16 "${LIM[@]}" --test-gate 0
HELD=$(post_small 16 1)
wait_until 30 holds 16 1
RAYD_TEST_VERSION=9.9.7-limits start_node 17 "${LIM[@]}" --test-gate open --max-work 1000
LID=$(post_small 16 2) # admitted by node 16, whose limits it is within
wait_until 30 grep -q "job $LID frame 0 tile 0 failed here (attempt 1 of 3), left for another node" "$T/node17.err"
check limited_tile_left "node 17: $(grep "job $LID" "$T/node17.err" | tail -n 2)" \
    grep -q "job $LID frame 0 tile 0 failed here (attempt 1 of 3), left for another node" "$T/node17.err"
kill -KILL "${NODE_PID[17]}"
wait "${NODE_PID[17]}" 2>/dev/null
gate_node 16 open
wait_until 30 succeeded 16 "$LID"
check limited_tile_rendered_elsewhere "state: $(job_state "${NODE_URL[16]}" "$LID")" succeeded 16 "$LID"
curl -s -m 30 -o "$T/limited.png" "${NODE_URL[16]}/v1/jobs/$LID/image.png"
"$RENDER" "$T/small2.json" -o "$T/ref_small.png" 2>/dev/null
check limited_tile_byte_identical "the image differs from rayd-render's" cmp -s "$T/limited.png" "$T/ref_small.png"
check limited_first_job_too "state: $(job_state "${NODE_URL[16]}" "$HELD")" succeeded 16 "$HELD"

gate_node 16 0
HELD=$(post_small 16 3)
wait_until 30 holds 16 1
RAYD_TEST_VERSION=9.9.7-limits start_node 18 "${LIM[@]}" --test-gate open --max-work 1000
WID=$(post_small 16 4)
left_again() { [ "$(grep -c "left again for another node" "$T/node18.err")" -ge "$1" ]; }
wait_until 60 left_again 4
check limited_waits_for_busy_node "node 18: $(grep -c "job $WID frame 0 tile 0 failed here" "$T/node18.err") failures, $(grep -c 'left again for another node' "$T/node18.err") take-backs left; state $(job_state "${NODE_URL[16]}" "$WID")" \
    bash -c "[ \$(grep -c 'job $WID frame 0 tile 0 failed here' '$T/node18.err') = 1 ] && [ \$(grep -c 'left again for another node' '$T/node18.err') -ge 4 ] && ! grep -q 'job $WID: a tile failed' '$T/node18.err'"
gate_node 16 open
wait_until 30 succeeded 16 "$WID"
check limited_busy_node_renders_it "state: $(job_state "${NODE_URL[16]}" "$WID")" succeeded 16 "$WID"
curl -s -m 30 -o "$T/waited.png" "${NODE_URL[16]}/v1/jobs/$WID/image.png"
"$RENDER" "$T/small4.json" -o "$T/ref_small4.png" 2>/dev/null
check limited_waited_byte_identical "the image differs from rayd-render's" cmp -s "$T/waited.png" "$T/ref_small4.png"
wait_until 30 succeeded 16 "$HELD"
# The same with node 16 busy on a job of another priority: it refreshes only the stream of the item
# it holds, and is live all the same.  Before, node 18 took node 16's silence on the normal stream
# for a gone node and tried the tile again (2 failures at the 3rd take-back).
gate_node 16 0
HELD=$(post_small 16 7 priority=high)
wait_until 30 holds 16 1
PID2=$(post_small 16 8)
n0=$(grep -c "left again for another node" "$T/node18.err")
wait_until 60 left_again $((n0 + 4))
check limited_waits_for_node_busy_elsewhere "node 18: $(grep -c "job $PID2 frame 0 tile 0 failed here" "$T/node18.err") failures, $(($(grep -c 'left again for another node' "$T/node18.err") - n0)) take-backs left; state $(job_state "${NODE_URL[16]}" "$PID2")" \
    bash -c "[ \$(grep -c 'job $PID2 frame 0 tile 0 failed here' '$T/node18.err') = 1 ] && ! grep -q 'job $PID2: a tile failed' '$T/node18.err'"
gate_node 16 open
wait_until 30 succeeded 16 "$PID2"
check limited_busy_elsewhere_renders_it "state: $(job_state "${NODE_URL[16]}" "$PID2")" succeeded 16 "$PID2"
wait_until 30 succeeded 16 "$HELD"

# Once the only other node is gone, node 18 is the only live node left: after its
# take-backs it tries the tile itself, three attempts in all, and the job fails naming the tile.
gate_node 16 0
HELD=$(post_small 16 5)
wait_until 30 holds 16 1
FID=$(post_small 16 6)
wait_until 30 grep -q "job $FID frame 0 tile 0 failed here (attempt 1 of 3)" "$T/node18.err"
kill -KILL "${NODE_PID[16]}"
wait "${NODE_PID[16]}" 2>/dev/null
failed_job() { curl -s "${NODE_URL[18]}/v1/jobs/$FID" | grep -q '"state":"failed"'; }
wait_until 90 failed_job
curl -s "${NODE_URL[18]}/v1/jobs/$FID" >"$T/failed.json"
check failed_job_error "$(head -c 400 "$T/failed.json")" python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
e = d.get("error", {})
sys.exit(0 if d["state"] == "failed" and e.get("code") == "too_large" and
         e.get("message", "").startswith("frame 0, tile 0 failed after 3 attempts: ") else 1)' "$T/failed.json"
check failed_job_tried_three_times "node 18: $(grep -c "job $FID frame 0 tile 0 failed here" "$T/node18.err") failures left" \
    bash -c "[ \$(grep -c 'job $FID frame 0 tile 0 failed here' '$T/node18.err') = 2 ]"
code=$(curl -s -o "$T/failed_img.json" -w '%{http_code}' "${NODE_URL[18]}/v1/jobs/$FID/image.png")
check failed_job_image_409 "image.png gave $code: $(head -c 200 "$T/failed_img.json")" bash -c "[ $code = 409 ] && grep -q job_failed '$T/failed_img.json'"
queued_none() { [ "$(metric 18 rayd_cluster_items_queued)" = 0 ]; }
wait_until 90 queued_none
check failed_job_items_dropped "items queued: $(metric 18 rayd_cluster_items_queued)" queued_none
kill -KILL "${NODE_PID[18]}"
wait "${NODE_PID[18]}" 2>/dev/null

# --- kill -9 the node making a frame range's video: another node makes it --------------------
# Nodes of a version of their own (so only they take these jobs), one thread each: node 12 holds
# a tile of a still job behind its gate, so node 11 renders the frame range and takes its video,
# whose ffmpeg (a stand-in that waits) it is killed in; node 12, its gate open, takes it over.
mkdir -p "$T/slowbin"
printf '#!/bin/sh\necho $$ >"%s/ffmpeg.pid"\nexec sleep 60\n' "$T" >"$T/slowbin/ffmpeg"
chmod +x "$T/slowbin/ffmpeg"
VARGS=(--threads 1 --cluster-tile 64 --redis-claim-ms 1500 --test-gate 0 --redis "$REDIS_URL")
PATH="$T/slowbin:$PATH" RAYD_TEST_VERSION=9.9.8-video start_node 11 "${VARGS[@]}"
RAYD_TEST_VERSION=9.9.8-video start_node 12 "${VARGS[@]}"
gate_node 11 open
post_job 12 >/dev/null
wait_until 30 holds 12 1
ANIM=$RAYD_ROOT/scenes/animation.json
VID=$(curl -s -m 30 "${JSON[@]}" --data-binary @"$ANIM" "${NODE_URL[12]}/v1/jobs?frames=3-4&priority=high" |
    python3 -c 'import json,sys; print(json.load(sys.stdin).get("id", ""))')
wait_until 60 grep -q "job $VID: making its video" "$T/node11.err"
check video_started_on_11 "node 11 did not start the video: $(tail -n 3 "$T/node11.err")" grep -q "job $VID: making its video" "$T/node11.err"
kill -KILL "${NODE_PID[11]}"
wait "${NODE_PID[11]}" 2>/dev/null
wait_until 10 test -s "$T/ffmpeg.pid"
FPID=$(cat "$T/ffmpeg.pid" 2>/dev/null)
ffmpeg_gone() { local st; st=$(ps -o stat= -p "${FPID:-0}" 2>/dev/null); [ -z "$st" ] || [[ $st == Z* ]]; }
[ -n "$FPID" ] && kill "$FPID" 2>/dev/null # orphaned by the kill -9; SIGTERM must stop it
wait_until 10 ffmpeg_gone
check ffmpeg_stops_on_sigterm "ffmpeg ($FPID) outlived SIGTERM: it kept the signals rayd blocks" ffmpeg_gone
ffmpeg_gone || kill -KILL "$FPID"
gate_node 12 open
video_ok() { [ "$(curl -s -m 30 -o "$T/taken.mp4" -w '%{http_code}' "${NODE_URL[12]}/v1/jobs/$VID/video.mp4")" = 200 ]; }
wait_until 60 video_ok
probe=$(ffprobe -v error -select_streams v:0 -count_frames -show_entries \
    stream=codec_name,width,height,r_frame_rate,nb_read_frames,pix_fmt -of csv=p=0 "$T/taken.mp4" 2>&1)
check video_taken_over "video.mp4: $probe; node 12: $(grep -c "job $VID: its video is made" "$T/node12.err")" \
    bash -c "[ '$probe' = 'h264,320,180,yuv420p,24/1,2' ] && grep -q 'took over item .* (job $VID frame 3 tile -2)' '$T/node12.err'"
kill -KILL "${NODE_PID[12]}"

for i in 2 3 5 6; do
    kill -0 "${NODE_PID[$i]}" 2>/dev/null || fail "node_${i}_alive" "node $i died: $(tail -n 3 "$T/node$i.err")"
done
pass nodes_alive

# --- a busy node takes a dead node's item over, not only once the queue runs dry ---------------
# node 14 holds one item and dies; node 13 (one worker) is kept busy by the gate, one tile at a
# time, each freed slot filled at once.  Its reclaim ran only on a tick that found a free slot,
# so it took the dead node's item last, when nothing was left to pull.
for i in 2 3 5 6; do kill -KILL "${NODE_PID[$i]}" 2>/dev/null; wait "${NODE_PID[$i]}" 2>/dev/null; done
BUSY=(--threads 1 --cluster-tile 64 --redis-claim-ms 1500 --test-gate 0 --redis "$REDIS_URL")
start_node 13 "${BUSY[@]}"
BID=$(post_job 13 'x=0&y=0&w=256&h=192') # 12 tiles
wait_until 30 holds 13 1
start_node 14 "${BUSY[@]}"
wait_until 30 holds 14 1
kill -KILL "${NODE_PID[14]}"
wait "${NODE_PID[14]}" 2>/dev/null
taken_at=
for step in $(seq 1 11); do
    gate_node 13 1
    wait_until 10 bash -c "curl -s '${NODE_URL[13]}/v1/jobs/$BID' | grep -q '\"tiles_done\":$step,'"
    if grep -q "took over item .*job $BID" "$T/node13.err"; then taken_at=$step; break; fi
    sleep 0.3
done
check reclaim_while_busy "taken over after $taken_at of 12 tiles done (claim 1.5 s, a tile each 0.3 s or more)" \
    bash -c "[ -n '$taken_at' ] && [ '$taken_at' -le 9 ]"
gate_node 13 open
wait_until 60 succeeded 13 "$BID"
check reclaim_while_busy_finishes "state: $(job_state "${NODE_URL[13]}" "$BID")" succeeded 13 "$BID"

# --- a --redis nobody answers at, from the start: said at once --------------------------------
# (a mistyped address was said nowhere until the first POST /v1/jobs got its 503)
start_node 15 --threads 1 --redis "redis://127.0.0.1:1"
wait_until 10 grep -q "Redis at 127.0.0.1:1 is down" "$T/node15.err"
check redis_unreachable_at_start_warned "$(tail -n 2 "$T/node15.err")" \
    grep -q "warn cluster: Redis at 127.0.0.1:1 is down: .*POST /v1/jobs answers 503" "$T/node15.err"
[ "$NFAIL" = 0 ]
