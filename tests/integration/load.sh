#!/usr/bin/env bash
# load.sh -- back-pressure and fairness: a burst over --queue gets 503 +
# Retry-After (queue_full), identical requests in flight render once, a
# small request overtakes a bulk render, and a client that disconnects
# cancels its render.
source "$(dirname "$0")/lib/common.sh"

# --- queue full -----------------------------------------------------------------------
start_rayd --threads 1 --queue 1
bg=()
size=(1280 960 8) # a second or more each: the queue is still full 0.3 s on
sanitized && size=(640 480 8)
for k in 1 2 3 4 5 6; do
    scene "$T/b$k.json" "${size[@]}" spheres "$k"
done
for k in 1 2 3 4 5 6; do
    ( code=$(curl -s -m 60 -o "$T/r$k.body" -D "$T/r$k.h" -w '%{http_code}' -X POST \
        -H 'Content-Type: application/json' --data-binary @"$T/b$k.json" "$URL/v1/render")
      echo "$code" >"$T/r$k.code" ) &
    PIDS+=($!)
    bg+=($!)
done
sleep 0.3
code=$(req GET /readyz)
check readyz_503_when_full "status $code" err_is "$T/body" 503 queue_full
wait "${bg[@]}"
ok200=0; ok503=0; bad=
for k in 1 2 3 4 5 6; do
    c=$(cat "$T/r$k.code")
    if [ "$c" = 200 ] && is_png "$T/r$k.body"; then ok200=$((ok200 + 1))
    elif [ "$c" = 503 ] && err_is "$T/r$k.body" 503 queue_full && grep -qi '^retry-after: [0-9]' "$T/r$k.h"; then ok503=$((ok503 + 1))
    else bad="$bad $k:$c"; fi
done
check burst_some_served "200s: $ok200" [ "$ok200" -ge 1 ]
check burst_queue_full_503 "503s: $ok503 (want >= 3)" [ "$ok503" -ge 3 ]
check burst_no_other_status "unexpected:$bad" [ -z "$bad" ]
check rejections_counted "rayd_rejections_total{queue_full} = $(metric 'rayd_rejections_total{reason="queue_full"}')" \
    [ "$(metric 'rayd_rejections_total{reason="queue_full"}')" = "$ok503" ]
check readyz_200_after "status" [ "$(req GET /readyz)" = 200 ]
stop_rayd TERM

# --- identical requests in flight are rendered once -------------------------------------
start_rayd --threads 2
if sanitized; then scene "$T/same.json" 640 480 4 spheres; else scene "$T/same.json" 1280 960 4 spheres; fi
bg=()
for k in 1 2 3 4; do
    curl -s -m 60 -o "$T/s$k.png" -X POST -H 'Content-Type: application/json' \
        --data-binary @"$T/same.json" "$URL/v1/render" &
    PIDS+=($!)
    bg+=($!)
done
wait "${bg[@]}"
check coalesced_same_bytes "answers differ" bash -c "cmp -s '$T/s1.png' '$T/s2.png' && cmp -s '$T/s1.png' '$T/s3.png' && cmp -s '$T/s1.png' '$T/s4.png' && head -c 4 '$T/s1.png' | grep -q PNG"
co=$(metric rayd_coalesced_total)
check coalesced_counted "rayd_coalesced_total = $co" [ "${co:-0}" -ge 1 ]
check coalesced_render_count "render count $(metric rayd_render_seconds_count), coalesced $co" \
    [ "$(( $(metric rayd_render_seconds_count) + co ))" = 4 ]
stop_rayd TERM

# --- a small request overtakes a bulk render; a disconnect cancels ---------------------------
start_rayd --threads 1
scene "$T/bulk.json" 1280 960 16 spheres
scene "$T/tile.json" 640 480 1 whitted
code=$(post_json /v1/jobs "$T/bulk.json")
bulk=$(jfield "$T/body" id)
sleep 0.3
t0=$(date +%s%N)
code=$(post_json "/v1/render?x=64&y=64&w=64&h=64" "$T/tile.json")
ms=$(( ($(date +%s%N) - t0) / 1000000 ))
req GET "/v1/jobs/$bulk" >/dev/null
st=$(jfield "$T/body" state)
check interactive_overtakes_bulk "tile status $code after ${ms} ms, bulk $st" bash -c "[ $code = 200 ] && [ $st = running ]"
req DELETE "/v1/jobs/$bulk" >/dev/null

c0=$(metric 'rayd_canceled_total{reason="client_gone"}')
scene "$T/slow.json" 1280 960 16 spheres 3
curl -s -m 1 -o /dev/null -X POST -H 'Content-Type: application/json' \
    --data-binary @"$T/slow.json" "$URL/v1/render"
busy=1
for i in $(seq 1 100); do
    busy=$(metric rayd_workers_busy)
    [ "$busy" = 0 ] && break
    sleep 0.05
done
c1=$(metric 'rayd_canceled_total{reason="client_gone"}')
check disconnect_cancels "canceled{client_gone} $c0 -> $c1" [ "$c1" = $((c0 + 1)) ]
check disconnect_frees_worker "worker still busy" [ "$busy" = 0 ]
sleep 0.2
check disconnect_logged "no 499 client_gone line" grep -q 'POST /v1/render 499 .*client_gone' "$T/rayd.err"
check alive_after_disconnect "healthz" [ "$(req GET /healthz)" = 200 ]
stop_rayd TERM
check exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
