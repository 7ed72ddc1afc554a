#!/usr/bin/env bash
# lifecycle.sh -- SIGTERM/SIGINT drain: /readyz turns 503, new work is
# refused with 503 draining, renders in flight finish and are answered, and
# the exit status is 0; past --drain-seconds the rest is cancelled and every
# waiting client still gets an answer.
source "$(dirname "$0")/lib/common.sh"

# --- renders in flight finish ---------------------------------------------------------
start_rayd --threads 2 --drain-seconds 30
# long enough to be in flight through the checks below (a second or more)
# and short enough to finish within --drain-seconds: under ThreadSanitizer
# (make test-tsan) renders are ~10x slower, under ASan (SANITIZE=1) ~4x
med=(1920 1440 16)
if ldd "$RAYD" 2>/dev/null | grep -q libtsan; then med=(960 720 4); fi
if ldd "$RAYD" 2>/dev/null | grep -q libasan; then med=(1280 960 8); fi
scene "$T/med.json" "${med[@]}" spheres
scene "$T/other.json" 64 64 1 spheres
curl -s -m 60 -o "$T/inflight.png" -w '%{http_code}' -X POST -H 'Content-Type: application/json' \
    --data-binary @"$T/med.json" "$URL/v1/render" >"$T/inflight.code" &
cp1=$!
PIDS+=($cp1)
sleep 0.3
kill -TERM "$RAYD_PID"
sleep 0.1
code=$(req GET /readyz)
check drain_readyz_503 "status $code" err_is "$T/body" 503 draining
code=$(post_json /v1/render "$T/other.json")
check drain_refuses_render "status $code" err_is "$T/body" 503 draining
check drain_retry_after "Retry-After '$(header Retry-After)'" [ -n "$(header Retry-After)" ]
code=$(post_json /v1/jobs "$T/other.json")
check drain_refuses_jobs "status $code" err_is "$T/body" 503 draining
check drain_healthz_200 "healthz" [ "$(req GET /healthz)" = 200 ]
wait "$cp1"
check drain_inflight_answered "status $(cat "$T/inflight.code")" bash -c "[ \"\$(cat '$T/inflight.code')\" = 200 ] && head -c 4 '$T/inflight.png' | grep -q PNG"
stop_rayd TERM
check drain_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
check drain_logged "no drain line" grep -q 'draining' "$T/rayd.err"

# --- past --drain-seconds the rest is cancelled, every client answered ----------------------
start_rayd --threads 1 --drain-seconds 1
scene "$T/slow.json" 1920 1440 16 spheres # seconds on one thread: cut by the deadline
scene "$T/slow2.json" 1920 1440 16 spheres 2
curl -s -m 60 -o "$T/c.body" -w '%{http_code}' -X POST -H 'Content-Type: application/json' \
    --data-binary @"$T/slow.json" "$URL/v1/render" >"$T/c.code" &
cp2=$!
PIDS+=($cp2)
post_json /v1/jobs "$T/slow2.json" >/dev/null
job=$(jfield "$T/body" id)
curl -s -N -m 60 "$URL/v1/jobs/$job/events" >"$T/sse.txt" &
cp3=$!
PIDS+=($cp3)
sleep 0.5
t0=$(date +%s%N)
stop_rayd INT
ms=$(( ($(date +%s%N) - t0) / 1000000 ))
check deadline_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
check deadline_prompt "took ${ms} ms" [ "$ms" -lt 6000 ]
wait "$cp2" "$cp3"
check deadline_client_answered "status $(cat "$T/c.code") $(head -c 200 "$T/c.body")" err_is "$T/c.body" 503 draining
check deadline_sse_done "$(tail -c 200 "$T/sse.txt")" bash -c "grep -A1 '^event: done' '$T/sse.txt' | grep -q canceled"
check deadline_cancel_logged "no cancel line" grep -q 'cancelled (drain)' "$T/rayd.err"
