#!/usr/bin/env bash
# lifecycle.sh -- SIGTERM/SIGINT drain: /readyz turns 503, new work is
# refused with 503 draining, renders in flight finish and are answered, and
# the exit status is 0; past --drain-seconds the rest is cancelled and every
# waiting client still gets an answer.  SIGHUP, SIGUSR1 and SIGUSR2 are
# logged and change nothing: the render in flight goes on.
#
# The renders in flight are held by the test gate (--test-gate 0: no tile
# starts until the test says so), so they are in flight through every check
# however fast or slow the machine, and the deadline case cannot finish
# before its deadline.
source "$(dirname "$0")/lib/common.sh"

# --- renders in flight finish ---------------------------------------------------------
start_rayd --threads 2 --drain-seconds 600 --test-gate 0
scene "$T/med.json" 320 240 2 spheres
scene "$T/other.json" 64 64 1 spheres
curl -s -m 300 -o "$T/inflight.png" -w '%{http_code}' -X POST -H 'Content-Type: application/json' \
    --data-binary @"$T/med.json" "$URL/v1/render" >"$T/inflight.code" &
cp1=$!
PIDS+=($cp1)
wait_until 60 gate_is queued 1
check drain_render_in_flight "gate: $(cat "$T/gate.json")" gate_is queued 1
kill -TERM "$RAYD_PID"
wait_until 60 bash -c "[ \"\$(curl -s -o /dev/null -w '%{http_code}' '$URL/readyz')\" = 503 ]"
code=$(req GET /readyz)
check drain_readyz_503 "status $code" err_is "$T/body" 503 draining
code=$(post_json /v1/render "$T/other.json")
check drain_refuses_render "status $code" err_is "$T/body" 503 draining
check drain_retry_after "Retry-After '$(header Retry-After)'" [ -n "$(header Retry-After)" ]
code=$(post_json /v1/jobs "$T/other.json")
check drain_refuses_jobs "status $code" err_is "$T/body" 503 draining
check drain_healthz_200 "healthz" [ "$(req GET /healthz)" = 200 ]
check drain_still_running "rayd exited with the render held" kill -0 "$RAYD_PID"
gate open
wait "$cp1"
"$RENDER" "$T/med.json" -o "$T/med_ref.png" 2>/dev/null
check drain_inflight_answered "status $(cat "$T/inflight.code")" bash -c "[ \"\$(cat '$T/inflight.code')\" = 200 ] && cmp -s '$T/inflight.png' '$T/med_ref.png'"
stop_rayd TERM
check drain_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
check drain_logged "no drain line" grep -q 'draining' "$T/rayd.err"

# --- past --drain-seconds the rest is cancelled, every client answered ----------------------
# The gate stays shut: neither render can ever finish, so only the deadline
# ends them.
start_rayd --threads 1 --drain-seconds 1 --test-gate 0
scene "$T/slow.json" 320 240 2 spheres
scene "$T/slow2.json" 320 240 2 spheres 2
curl -s -m 300 -o "$T/c.body" -w '%{http_code}' -X POST -H 'Content-Type: application/json' \
    --data-binary @"$T/slow.json" "$URL/v1/render" >"$T/c.code" &
cp2=$!
PIDS+=($cp2)
post_json /v1/jobs "$T/slow2.json" >/dev/null
job=$(jfield "$T/body" id)
curl -s -N -m 300 "$URL/v1/jobs/$job/events" >"$T/sse.txt" &
cp3=$!
PIDS+=($cp3)
wait_until 60 gate_is queued 2
wait_until 60 metric_is rayd_http_suspended 2
check deadline_both_held "gate $(cat "$T/gate.json"), suspended $(metric rayd_http_suspended)" \
    bash -c "[ '$(jfield "$T/gate.json" queued)' = 2 ] && [ '$(metric rayd_http_suspended)' = 2 ]"
stop_rayd INT
check deadline_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
check deadline_cut "no 'drain: deadline' line" grep -q 'drain: deadline, cancelling' "$T/rayd.err"
wait "$cp2" "$cp3"
check deadline_client_answered "status $(cat "$T/c.code") $(head -c 200 "$T/c.body")" err_is "$T/c.body" 503 draining
check deadline_sse_done "$(tail -c 200 "$T/sse.txt")" bash -c "grep -A1 '^event: done' '$T/sse.txt' | grep -q canceled"
check deadline_cancel_logged "no cancel line" grep -q 'cancelled (drain)' "$T/rayd.err"

# --- SIGHUP, SIGUSR1, SIGUSR2: logged, the render in flight goes on ---------------------
# Their default action would end rayd at once, without a drain (an
# operator's "reload", a closed terminal): the held render must survive them.
start_rayd --threads 1 --test-gate 0
scene "$T/hup.json" 64 64 1 spheres
curl -s -m 300 -o "$T/hup.png" -w '%{http_code}' -X POST -H 'Content-Type: application/json' \
    --data-binary @"$T/hup.json" "$URL/v1/render" >"$T/hup.code" &
cp4=$!
PIDS+=($cp4)
wait_until 60 gate_is queued 1
for sig in HUP USR1 USR2; do
    kill -"$sig" "$RAYD_PID"
done
hup_logged() { [ "$(grep -c 'ignored: rayd has nothing to reload' "$T/rayd.err")" = 3 ]; }
wait_until 60 hup_logged
check hup_logged "$(grep -m 3 signal "$T/rayd.err")" hup_logged
check hup_still_running "rayd died on SIGHUP/SIGUSR1/SIGUSR2" kill -0 "$RAYD_PID"
check hup_still_ready "readyz $(req GET /readyz)" [ "$(req GET /readyz)" = 200 ]
gate open
wait "$cp4"
"$RENDER" "$T/hup.json" -o "$T/hup_ref.png" 2>/dev/null
check hup_render_answered "status $(cat "$T/hup.code")" bash -c "[ \"\$(cat '$T/hup.code')\" = 200 ] && cmp -s '$T/hup.png' '$T/hup_ref.png'"
stop_rayd TERM
check hup_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
