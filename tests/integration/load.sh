#!/usr/bin/env bash
# load.sh -- back-pressure and fairness: a burst over --queue gets 503 +
# Retry-After (queue_full), identical requests in flight render once, a
# small request overtakes a bulk render, and a client that disconnects
# cancels its render.
#
# Every case holds its work in flight with the test gate (--test-gate 0),
# so "the queue is full" or "the render is still running" is a state the
# test sets before it looks, on any machine.
source "$(dirname "$0")/lib/common.sh"

# --- queue full -----------------------------------------------------------------------
# One worker, a queue of one, the gate shut: the first render waits in the
# queue, the other five find it full.
start_rayd --threads 1 --queue 1 --test-gate 0
bg=()
for k in 1 2 3 4 5 6; do
    scene "$T/b$k.json" 128 96 2 spheres "$k"
done
for k in 1 2 3 4 5 6; do
    ( code=$(curl -s -m 300 -o "$T/r$k.body" -D "$T/r$k.h" -w '%{http_code}' -X POST \
        -H 'Content-Type: application/json' --data-binary @"$T/b$k.json" "$URL/v1/render")
      echo "$code" >"$T/r$k.code" ) &
    PIDS+=($!)
    bg+=($!)
done
wait_until 60 metric_is 'rayd_rejections_total{reason="queue_full"}' 5
code=$(req GET /readyz)
check readyz_503_when_full "status $code" err_is "$T/body" 503 queue_full
gate open
wait "${bg[@]}"
ok200=0; ok503=0; bad=
for k in 1 2 3 4 5 6; do
    c=$(cat "$T/r$k.code")
    if [ "$c" = 200 ] && is_png "$T/r$k.body"; then ok200=$((ok200 + 1))
    elif [ "$c" = 503 ] && err_is "$T/r$k.body" 503 queue_full && grep -qi '^retry-after: [0-9]' "$T/r$k.h"; then ok503=$((ok503 + 1))
    else bad="$bad $k:$c"; fi
done
check burst_one_served "200s: $ok200" [ "$ok200" = 1 ]
check burst_queue_full_503 "503s: $ok503 (want 5)" [ "$ok503" = 5 ]
check burst_no_other_status "unexpected:$bad" [ -z "$bad" ]
check rejections_counted "rayd_rejections_total{queue_full} = $(metric 'rayd_rejections_total{reason="queue_full"}')" \
    [ "$(metric 'rayd_rejections_total{reason="queue_full"}')" = "$ok503" ]
check readyz_200_after "status" [ "$(req GET /readyz)" = 200 ]
stop_rayd TERM

# --- identical requests in flight are rendered once -------------------------------------
# The gate holds the first request's render until the other three have
# joined it.
start_rayd --threads 2 --test-gate 0
scene "$T/same.json" 320 240 2 spheres
bg=()
for k in 1 2 3 4; do
    curl -s -m 300 -o "$T/s$k.png" -X POST -H 'Content-Type: application/json' \
        --data-binary @"$T/same.json" "$URL/v1/render" &
    PIDS+=($!)
    bg+=($!)
done
wait_until 60 metric_is rayd_coalesced_total 3
check coalesced_counted "rayd_coalesced_total = $(metric rayd_coalesced_total)" metric_is rayd_coalesced_total 3
gate open
wait "${bg[@]}"
check coalesced_same_bytes "answers differ" bash -c "cmp -s '$T/s1.png' '$T/s2.png' && cmp -s '$T/s1.png' '$T/s3.png' && cmp -s '$T/s1.png' '$T/s4.png' && head -c 4 '$T/s1.png' | grep -q PNG"
check coalesced_render_count "render count $(metric rayd_render_seconds_count)" metric_is rayd_render_seconds_count 1
stop_rayd TERM

# --- a small request overtakes a bulk render; a disconnect cancels ---------------------------
# One worker.  The bulk job gets one tile and is held; the small render
# arrives; one more tile is let through, and it must be the small render's.
start_rayd --threads 1 --test-gate 1
scene "$T/bulk.json" 1280 960 16 spheres
scene "$T/tile.json" 640 480 1 spheres 5 # a 64x64 region is one tile (a glass scene is priced for its whole tree, in smaller tiles)
code=$(post_json /v1/jobs "$T/bulk.json")
bulk=$(jfield "$T/body" id)
wait_until 60 gate_is held 1
curl -s -m 300 -o "$T/tile.png" -w '%{http_code}' -X POST -H 'Content-Type: application/json' \
    --data-binary @"$T/tile.json" "$URL/v1/render?x=64&y=64&w=64&h=64" >"$T/tile.code" &
tp=$!
PIDS+=($tp)
wait_until 60 gate_is queued 2
gate 1
wait "$tp"
code=$(cat "$T/tile.code")
req GET "/v1/jobs/$bulk" >/dev/null
st=$(jfield "$T/body" state) td=$(jfield "$T/body" tiles_done)
check interactive_overtakes_bulk "tile status $code, bulk $st with $td tiles" \
    bash -c "[ '$code' = 200 ] && [ '$st' = running ] && [ '$td' = 1 ]"
req DELETE "/v1/jobs/$bulk" >/dev/null

# A bulk backlog of any age does not delay a small request: the bulk job
# has waited more than 2 s (a lower bound: time only moves forward) when
# the small render arrives, and the next tile is still the small one's.
# While both wait, bulk still gets one tile in four.
gate 0
code=$(post_json /v1/jobs "$T/bulk.json")
bulk=$(jfield "$T/body" id)
gate 1
wait_until 60 job_is "$bulk" tiles_done 1
wait_until 60 gate_is held 1
sleep 2.5
scene "$T/tiles.json" 640 480 1 spheres 7 # 64x64 regions, one tile and one request each
for k in 0 1 2 3 4 5; do
    curl -s -m 300 -o /dev/null -w '%{http_code}' -X POST -H 'Content-Type: application/json' \
        --data-binary @"$T/tiles.json" "$URL/v1/render?x=$((64 * k))&y=0&w=64&h=64" >"$T/small$k.code" &
    PIDS+=($!)
done
wait_until 60 gate_is queued 7
gate 1
small_done() { cat "$T"/small*.code 2>/dev/null | grep -o 200 | wc -l; } # answered so far
one_small() { [ "$(small_done)" -ge 1 ]; }
wait_until 60 one_small
req GET "/v1/jobs/$bulk" >/dev/null
check old_bulk_does_not_delay_small "bulk has $(jfield "$T/body" tiles_done) tiles done" job_is "$bulk" tiles_done 1
# three more tiles: two small, then the bulk job's share (the fourth tile)
gate 3
bulk_done() { req GET "/v1/jobs/$bulk" >/dev/null; jfield "$T/body" tiles_done; }
tiles_after() { [ $(($(small_done) + $(bulk_done))) -ge 5 ]; }
wait_until 60 tiles_after
check bulk_keeps_a_share "after 3 more tiles: $(small_done) small answered, bulk $(bulk_done) tiles" \
    bash -c "[ $(small_done) = 3 ] && [ $(bulk_done) = 2 ]"
gate open
all_small() { [ "$(small_done)" = 6 ]; }
wait_until 60 all_small
req DELETE "/v1/jobs/$bulk" >/dev/null

# a client that leaves: its render (held at the gate) is cancelled, and no
# tile of it starts once the gate opens
c0=$(metric 'rayd_canceled_total{reason="client_gone"}')
r0=$(metric rayd_render_seconds_count)
gate 0
scene "$T/slow.json" 320 240 2 spheres 3
# The client leaves once its render is held at the gate (curl -m 1 could
# give up before its request had even arrived on a loaded machine).
hold_request "$T/leave" "" POST /v1/render "$T/slow.json"
lp=$HOLD_PID
wait_until 60 gate_is queued 1
check disconnect_render_held "gate $(cat "$T/gate.json")" gate_is queued 1
touch "$T/leave.stop"
wait "$lp"
wait_until 60 metric_is 'rayd_canceled_total{reason="client_gone"}' $((c0 + 1))
c1=$(metric 'rayd_canceled_total{reason="client_gone"}')
check disconnect_cancels "canceled{client_gone} $c0 -> $c1" [ "$c1" = $((c0 + 1)) ]
gate_read
s0=$(jfield "$T/gate.json" started)
gate open
wait_until 60 gate_is queued 0
check disconnect_frees_worker "tiles started $s0 -> $(jfield "$T/gate.json" started), queued $(jfield "$T/gate.json" queued)" \
    bash -c "[ '$(jfield "$T/gate.json" started)' = '$s0' ] && [ '$(metric rayd_workers_busy)' = 0 ] && [ '$(metric rayd_render_seconds_count)' = '${r0:-0}' ]"
wait_until 60 grep -q 'POST /v1/render 499 .*client_gone' "$T/rayd.err"
check disconnect_logged "no 499 client_gone line" grep -q 'POST /v1/render 499 .*client_gone' "$T/rayd.err"
# the access line says it all: libmicrohttpd's "internal error" for the
# dropped connection is no warning of the server's
check disconnect_no_internal_error_warning "$(grep -m1 'warn http: Application' "$T/rayd.err")" \
    bash -c "! grep -q 'warn http: Application reported internal error' '$T/rayd.err'"
check alive_after_disconnect "healthz" [ "$(req GET /healthz)" = 200 ]
stop_rayd TERM
