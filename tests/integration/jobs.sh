#!/usr/bin/env bash
# jobs.sh -- asynchronous renders: POST /v1/jobs (202 + Location), polling
# GET /v1/jobs/{id} through queued/running to succeeded with progress, the
# image (202 + Retry-After before, 200 and equal to rayd-render after),
# Server-Sent Events (state, tile, progress, done), DELETE cancelling within
# a tile's time, and the bound on kept jobs.
source "$(dirname "$0")/lib/common.sh"

# Work in flight is held by the test gate (--test-gate), never by a render
# sized to be slow: the gate starts closed, and each case lets tiles through.
start_rayd --threads 2 --max-jobs 4 --test-gate 0
scene "$T/mid.json" 320 240 2 spheres
"$RENDER" "$T/mid.json" -o "$T/ref.png" 2>/dev/null

# --- create, poll, fetch ------------------------------------------------------------
code=$(post_json /v1/jobs "$T/mid.json")
id=$(jfield "$T/body" id)
check job_post_202 "status $code" [ "$code" = 202 ]
check job_id_form "id '$id'" bash -c "[[ '$id' =~ ^[0-9a-f]{32}$ ]]"
check job_location "$(header Location)" [ "$(header Location)" = "/v1/jobs/$id" ]
wait_until 30 gate_is held 2
check job_held_queued "state $(json "$T/body" 'j["state"]')" job_state_is "$id" queued
c2=$(req GET "/v1/jobs/$id/image.png")
retry=$(header Retry-After)
check job_image_202_while_running "status $c2, Retry-After '$retry'" bash -c "[ '$c2' = 202 ] && [ -n '$retry' ]"
check job_image_202_body "$(head -c 200 "$T/body")" bash -c "[[ '$(jfield "$T/body" state)' =~ ^(queued|running)$ ]]"
# 3 of the 20 tiles: the job is running, its progress strictly between 0 and 1
gate 3
wait_until 60 job_is "$id" tiles_done 3
req GET "/v1/jobs/$id" >/dev/null
check job_progress_between "$(head -c 300 "$T/body")" bash -c \
    "[ '$(jfield "$T/body" state)' = running ] && [ '$(jfield "$T/body" progress)' = 0.1500 ]"
gate open
wait_until 120 job_state_is "$id" succeeded
check job_succeeds "state $(jfield "$T/body" state)" [ "$(jfield "$T/body" state)" = succeeded ]
check job_final_progress_1 "$(cat "$T/body")" [ "$(jfield "$T/body" progress)" = 1.0000 ]
check job_encode_ms "$(cat "$T/body")" python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); sys.exit(0 if 0 < j["encode_ms"] <= j["render_ms"] else 1)' "$T/body"
code=$(req GET "/v1/jobs/$id/image.png")
check job_image_200 "status $code" [ "$code" = 200 ]
check job_image_equals_cli "differs from rayd-render" cmp -s "$T/body" "$T/ref.png"

# --- Server-Sent Events -----------------------------------------------------------------
scene "$T/sse.json" 320 240 2 spheres 1
code=$(post_json /v1/jobs "$T/sse.json")
id2=$(jfield "$T/body" id)
curl -s -N -m 60 -D "$T/sse.h" "$URL/v1/jobs/$id2/events" >"$T/sse.txt"
check sse_content_type "$(grep -i content-type "$T/sse.h")" grep -qi '^content-type: text/event-stream' "$T/sse.h"
check sse_events "bad stream: $(head -c 300 "$T/sse.txt")" env PYTHONPATH="$SSE_LIB" python3 - "$T/sse.txt" <<'PY'
import json, sys
import sse
events = sse.events(sys.argv[1])
names = [e.get("event") for e in events]
assert names[0] == "state", names[:3]
tiles = [json.loads(e["data"]) for e in events if e.get("event") == "tile"]
prog = [json.loads(e["data"])["progress"] for e in events if e.get("event") == "progress"]
done = [json.loads(e["data"]) for e in events if e.get("event") == "done"]
assert len(tiles) == 20, len(tiles)                 # 320x240 in 64-pixel tiles: 5 x 4
assert sum(t["w"] * t["h"] for t in tiles) == 320 * 240
assert prog == sorted(prog) and abs(prog[-1] - 1) < 1e-9, prog
assert len(done) == 1 and done[0]["state"] == "succeeded" and names[-1] == "done"
PY
# the stream of a finished job replays everything and ends at once
curl -s -N -m 10 "$URL/v1/jobs/$id2/events" >"$T/sse2.txt"
check sse_replay_finished "$(tail -c 200 "$T/sse2.txt")" bash -c "grep -q '^event: done' '$T/sse2.txt' && [ \$(grep -c '^event: tile' '$T/sse2.txt') = 20 ]"

# --- DELETE cancels within a tile's time --------------------------------------------------
# The gate lets 2 tiles through and holds the rest: the job is running when
# the DELETE comes, and no tile may start after it, however fast the machine.
gate 2
scene "$T/slow.json" 1280 960 4 spheres
code=$(post_json /v1/jobs "$T/slow.json")
id3=$(jfield "$T/body" id)
curl -s -N -m 120 "$URL/v1/jobs/$id3/events" >"$T/sse3.txt" &
ssepid=$!
PIDS+=($ssepid)
wait_until 60 job_is "$id3" tiles_done 2
check job_running "state $(json "$T/body" 'j["state"]')" job_state_is "$id3" running
c0=$(metric 'rayd_canceled_total{reason="delete"}')
gate_read
started0=$(jfield "$T/gate.json" started)
code=$(req DELETE "/v1/jobs/$id3")
check job_delete_200 "status $code" [ "$code" = 200 ]
check job_delete_state "$(cat "$T/body")" [ "$(json "$T/body" 'j["state"]')" = canceled ]
gate open
wait_until 30 metric_is rayd_workers_busy 0
check job_cancel_stops_workers "rayd_workers_busy $(metric rayd_workers_busy)" metric_is rayd_workers_busy 0
req GET "/v1/jobs/$id3" >/dev/null
done1=$(jfield "$T/body" tiles_done)
gate_read
started1=$(jfield "$T/gate.json" started)
check job_cancel_no_more_tiles "tiles done $done1 (2 at the DELETE), tiles started $started0 -> $started1" \
    bash -c "[ '$done1' = 2 ] && [ '$started1' = '$started0' ]"
check job_cancel_counted "canceled_total{delete} $c0 -> $(metric 'rayd_canceled_total{reason="delete"}')" \
    [ "$(metric 'rayd_canceled_total{reason="delete"}')" = $((c0 + 1)) ]
code=$(req GET "/v1/jobs/$id3/image.png")
check job_canceled_image_409 "status $code" err_is "$T/body" 409 job_canceled
wait $ssepid
check sse_done_canceled "$(tail -c 200 "$T/sse3.txt")" bash -c "grep -A1 '^event: done' '$T/sse3.txt' | grep -q canceled"
# a stream opened after the cancel replays the two tiles that were done, then done
curl -s -N -m 10 "$URL/v1/jobs/$id3/events" >"$T/sse3b.txt"
check sse_replay_after_cancel "$(head -c 400 "$T/sse3b.txt")" \
    bash -c "[ \$(grep -c '^event: tile' '$T/sse3b.txt') = 2 ] && grep -A1 '^event: done' '$T/sse3b.txt' | grep -q canceled"
code=$(req DELETE "/v1/jobs/$id3")
check job_delete_twice "status $code" [ "$code" = 200 ]

# --- a client leaving an event stream frees its connection; the job goes on -----------
gate 0
scene "$T/sse4.json" 640 480 16 spheres 4
post_json /v1/jobs "$T/sse4.json" >/dev/null
id5=$(jfield "$T/body" id)
# The client reads the stream's first event, so it is open and waiting on
# the server when it leaves (a client timing out after a fixed 0.4 s might
# not even have connected on a loaded machine).
hold_request "$T/sse5" "event: state" GET "/v1/jobs/$id5/events"
sse5=$HOLD_PID
wait_until 60 test -e "$T/sse5.ready"
wait_until 30 metric_is rayd_http_suspended 1
check sse_stream_open "first event: $(head -c 200 "$T/sse5.ready" 2>/dev/null), rayd_http_suspended $(metric rayd_http_suspended)" \
    bash -c "grep -q '^event: state' '$T/sse5.ready' && [ '$(metric rayd_http_suspended)' = 1 ]"
touch "$T/sse5.stop"
wait "$sse5"
wait_until 30 metric_is rayd_http_suspended 0
check sse_disconnect_resumed "rayd_http_suspended = $(metric rayd_http_suspended)" metric_is rayd_http_suspended 0
check sse_disconnect_job_goes_on "state $(jfield "$T/body" state)" job_state_is "$id5" queued
req DELETE "/v1/jobs/$id5" >/dev/null

# --- rayd-client job: Ctrl-C cancels the job on the server and exits 130 -------------------
# The gate is still closed, so the job is waiting when the signal comes.
"$RAYD_BUILD/rayd-client" job "$T/sse4.json" -o "$T/cj.png" --server "$URL" 2>"$T/cj.err" </dev/null &
cpid=$!
PIDS+=($cpid)
wait_until 30 grep -q '^rayd-client: job [0-9a-f]* on' "$T/cj.err"
idc=$(sed -n 's/^rayd-client: job \([0-9a-f]*\) on.*/\1/p' "$T/cj.err")
kill -INT "$cpid"
wait "$cpid"
crc=$?
check client_job_interrupt_130 "exit $crc, stderr: $(tail -n 2 "$T/cj.err")" \
    bash -c "[ $crc = 130 ] && grep -q '^rayd-client: interrupted; job $idc cancelled' '$T/cj.err' && [ ! -e '$T/cj.png' ]"
check client_job_interrupt_cancels "job $idc" job_state_is "$idc" canceled
gate open

# --- jobs with a region ------------------------------------------------------------------------
code=$(post_json "/v1/jobs?x=10&y=20&w=100&h=50" "$T/mid.json")
id4=$(jfield "$T/body" id)
wait_until 60 job_state_is "$id4" succeeded
req GET "/v1/jobs/$id4/image.png" >/dev/null
"$RENDER" "$T/mid.json" -o "$T/ref_r.png" --region 10,20,100,50 2>/dev/null
check job_region_equals_cli "differs" cmp -s "$T/body" "$T/ref_r.png"

# --- only --max-jobs are kept: the oldest finished one is forgotten --------------------------------
for k in 1 2 3 4; do
    scene "$T/k$k.json" 32 32 1 spheres "$k"
    post_json /v1/jobs "$T/k$k.json" >/dev/null
    last=$(json "$T/body" 'j["id"]')
    wait_until 60 job_state_is "$last" succeeded
done
check jobs_bounded "rayd_jobs = $(metric rayd_jobs)" [ "$(metric rayd_jobs)" = 4 ]
code=$(req GET "/v1/jobs/$id")
check oldest_job_forgotten "status $code: $(head -c 300 "$T/body")" err_is "$T/body" 410 job_evicted
check newest_job_kept "last job unknown" [ "$(req GET "/v1/jobs/$last")" = 200 ]
stop_rayd TERM
check exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- one client's flood of jobs forgets its own finished ones, not another's ------------------
start_rayd --threads 2 --max-jobs 4 --client-header X-Client
scene "$T/bob.json" 32 32 1 spheres 21
post_json /v1/jobs "$T/bob.json" -H 'X-Client: bob' >/dev/null
bob=$(jfield "$T/body" id)
wait_until 60 job_state_is "$bob" succeeded
alice=()
for k in 1 2 3 4 5 6; do
    scene "$T/al$k.json" 32 32 1 spheres "$((k + 21))"
    post_json /v1/jobs "$T/al$k.json" -H 'X-Client: alice' >/dev/null
    alice+=("$(jfield "$T/body" id)")
    wait_until 60 job_state_is "${alice[-1]}" succeeded
done
code=$(req GET "/v1/jobs/$bob")
check flood_keeps_others_job "bob's: $code $(head -c 200 "$T/body")" [ "$code" = 200 ]
code=$(req GET "/v1/jobs/${alice[0]}")
check flood_forgets_own_oldest "alice's first: $code $(head -c 200 "$T/body")" \
    err_is "$T/body" 410 job_evicted
stop_rayd TERM

# --- finished jobs are forgotten after --job-ttl ----------------------------------------------
# --job-ttl counts from a job's end: job A is held at the gate (never
# finished), job B, created after A, is cancelled (ended).  Once the watcher
# has forgotten B (410 job_expired), A is older than the TTL too and must
# still be known, because it has not ended; when it ends, it goes.
# (tests/integration/jobs_ttl.sh holds a render past the TTL.)
start_rayd --job-ttl 1 --test-gate 0
scene "$T/ttl.json" 32 32 1 spheres 5
scene "$T/ttl2.json" 32 32 1 spheres 6
post_json /v1/jobs "$T/ttl.json" >/dev/null
idt=$(jfield "$T/body" id)
post_json /v1/jobs "$T/ttl2.json" >/dev/null
idb=$(jfield "$T/body" id)
code=$(req DELETE "/v1/jobs/$idb")
check ttl_cancelled_job "status $code" [ "$code" = 200 ]
job_gone() { [ "$(curl -s -m 60 -o /dev/null -w '%{http_code}' "$URL/v1/jobs/$1")" = 410 ]; }
wait_until 60 job_gone "$idb"
check ttl_finished_job_forgotten "cancelled job still known after 60 s" job_gone "$idb"
check ttl_unfinished_job_kept "status $(req GET "/v1/jobs/$idt"), $(head -c 200 "$T/body")" \
    job_state_is "$idt" queued
gate open
wait_until 60 job_gone "$idt"
check ttl_job_forgotten "still known after 60 s" job_gone "$idt"
stop_rayd TERM

# --- a full job table: /readyz stays 200 (renders are accepted) and says why jobs are not ------
# The gate holds both jobs unfinished, so the table of --max-jobs 2 is full
# of jobs that cannot be evicted, while the render queue (--queue 8) is not.
start_rayd --max-jobs 2 --queue 8 --test-gate 0
scene "$T/f1.json" 32 32 1 spheres 7
scene "$T/f2.json" 32 32 1 spheres 8
scene "$T/f3.json" 32 32 1 spheres 9
post_json /v1/jobs "$T/f1.json" >/dev/null
idf1=$(jfield "$T/body" id)
code=$(req GET /readyz)
check readyz_jobs_room "status $code $(cat "$T/body")" bash -c \
    "[ $code = 200 ] && [ '$(jfield "$T/body" jobs)' = 1 ] && [ '$(jfield "$T/body" max_jobs)' = 2 ] && ! grep -q jobs_refused '$T/body'"
"$RAYD_BUILD/rayd-client" health --server "$URL" >"$T/health1.out" 2>&1
RC=$?
check client_health_counts_jobs "exit $RC: $(cat "$T/health1.out")" bash -c \
    "[ $RC = 0 ] && grep -q ', ready (queue [0-9]*/8, workers [0-9]* busy of [0-9]*, jobs 1/2)\$' '$T/health1.out'"
post_json /v1/jobs "$T/f2.json" >/dev/null
code=$(post_json /v1/jobs "$T/f3.json")
check jobs_table_full_503 "status $code $(head -c 200 "$T/body")" err_is "$T/body" 503 queue_full
code=$(req GET /readyz)
check readyz_says_jobs_refused "status $code $(cat "$T/body")" bash -c \
    "[ $code = 200 ] && [ '$(jfield "$T/body" status)' = ready ] && [ '$(jfield "$T/body" jobs)' = 2 ] && grep -q '\"jobs_refused\":\"all 2 jobs kept (--max-jobs) are unfinished' '$T/body'"
# rayd-client health shows it: the node is ready (renders are accepted), and
# says why new jobs are not
"$RAYD_BUILD/rayd-client" health --server "$URL" >"$T/health2.out" 2>&1
RC=$?
check client_health_says_jobs_refused "exit $RC: $(cat "$T/health2.out")" bash -c \
    "[ $RC = 0 ] && grep -q ', ready (.*, jobs 2/2; jobs refused: all 2 jobs kept (--max-jobs) are unfinished: POST /v1/jobs answers 503 queue_full' '$T/health2.out'"
req DELETE "/v1/jobs/$idf1" >/dev/null
code=$(req GET /readyz)
check readyz_jobs_room_again "status $code $(cat "$T/body")" bash -c \
    "[ $code = 200 ] && [ '$(jfield "$T/body" jobs)' = 1 ] && ! grep -q jobs_refused '$T/body'"
code=$(post_json /v1/jobs "$T/f3.json")
check job_accepted_again "status $code" [ "$code" = 202 ]
gate open
stop_rayd TERM
