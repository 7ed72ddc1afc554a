#!/usr/bin/env bash
# fair.sh -- work budgets and fair shares (docs/api.md "Cost, budgets and
# fair shares"):
#   - every render is priced before it starts: X-Rayd-Estimated-Rays equals
#     the estimate rayd-render --stats prints for the same scene and region;
#   - --max-work refuses a render (and a job) estimated over it with 413
#     over_budget naming the estimate and the limit; a region under it runs;
#   - a plain render estimated at more than 4x --max-render-seconds is
#     refused, a progressive job of it is not;
#   - tiles are sized by cost, and the pixels do not depend on the tiling;
#   - two clients get tiles in turn, however many jobs the first queued;
#   - /readyz turns 503 "backlog" past --max-backlog, and a 503 carries a
#     Retry-After from the backlog.
# The test gate holds the workers wherever work must be waiting, so no
# check depends on how fast the machine renders; the seconds checked are
# those of the rate a node assumes before it has timed any tile.
source "$(dirname "$0")/lib/common.sh"

# estimate FILE [X,Y,W,H]: the rays rayd-render --stats estimates
estimate() {
    local reg=()
    [ $# -gt 1 ] && reg=(--region "$2")
    "$RENDER" "$1" -o "$T/est.png" --threads 1 --stats "${reg[@]}" 2>&1 |
        sed -n 's/^rays estimated: //p'
}
# tile_side RAYS PIXELS: the tile side cost.c picks for RAYS over PIXELS
tile_side() {
    python3 -c 'import sys
rpp = float(sys.argv[1]) / float(sys.argv[2]); s = 64
while s > 8 and s * s * rpp > 1048576: s //= 2
print(s)' "$1" "$2"
}
ceil_div() { python3 -c 'import math,sys; print(math.ceil(float(sys.argv[1]) / float(sys.argv[2])))' "$1" "$2"; }

# small: priced at the node rate measured on the loaded, sanitized builds too,
# it must stay under the 1 s budget below
scene "$T/paper.json" 80 60 4 paper
scene "$T/big.json" 640 480 4 spheres
scene "$T/cb.json" 320 240 64 cornell
scene "$T/cb_small.json" 40 40 96 cornell

# --- --max-render-seconds as a budget, then the price -------------------------------------
# (the budget first, while the node still assumes its starting rate)
start_rayd --threads 1 --max-render-seconds 1
code=$(post_json /v1/render "$T/cb.json")
check deadline_budget_413 "status $code: $(head -c 300 "$T/body")" \
    bash -c "[ $code = 413 ] && grep -q 'max-render-seconds' '$T/body' && grep -q 'rays' '$T/body'"
check deadline_budget_code "$(head -c 300 "$T/body")" err_is "$T/body" 413 over_budget
code=$(post_json "/v1/jobs?progressive=1" "$T/cb.json")
id=$(jfield "$T/body" id)
check deadline_budget_progressive_admitted "status $code: $(head -c 300 "$T/body")" [ "$code" = 202 ]
check job_estimate "$(head -c 400 "$T/body")" \
    bash -c "[ '$(json "$T/body" 'j["estimate"]["rays"]')' = '$(estimate "$T/cb.json")' ]"
check job_estimate_header "'$(header X-Rayd-Estimated-Rays)'" \
    bash -c "[ '$(header X-Rayd-Estimated-Rays)' = '$(estimate "$T/cb.json")' ]"
req DELETE "/v1/jobs/$id" >/dev/null

code=$(post_json /v1/render "$T/paper.json")
want=$(estimate "$T/paper.json")
check price_header "status $code, header '$(header X-Rayd-Estimated-Rays)', rayd-render $want" \
    bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Estimated-Rays)' = '$want' ]"
check price_seconds_header "'$(header X-Rayd-Estimated-Seconds)'" \
    bash -c "[[ '$(header X-Rayd-Estimated-Seconds)' =~ ^[0-9]+\.[0-9]{3}$ ]]"
code=$(post_json "/v1/render?x=16&y=8&w=64&h=32" "$T/paper.json")
want=$(estimate "$T/paper.json" 16,8,64,32)
check price_of_region "status $code, header '$(header X-Rayd-Estimated-Rays)', rayd-render $want" \
    bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Estimated-Rays)' = '$want' ]"
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- --max-work ---------------------------------------------------------------------------
start_rayd --threads 2 --max-work 3000000
big=$(estimate "$T/big.json")
code=$(post_json /v1/render "$T/big.json")
check max_work_413 "status $code: $(head -c 300 "$T/body")" \
    bash -c "[ $code = 413 ] && grep -q -- '--max-work' '$T/body' && grep -q '3000000 rays' '$T/body'"
check max_work_names_estimate "estimate $big: $(head -c 300 "$T/body")" \
    grep -q "$(python3 -c "print('%.3g' % $big)") rays" "$T/body"
check max_work_code "$(head -c 300 "$T/body")" err_is "$T/body" 413 over_budget
code=$(post_json /v1/jobs "$T/big.json")
check max_work_job_413 "status $code: $(head -c 300 "$T/body")" err_is "$T/body" 413 over_budget
code=$(post_json "/v1/render?x=0&y=0&w=64&h=64" "$T/big.json")
check max_work_region_runs "status $code" [ "$code" = 200 ]
check max_work_region_png "not a PNG" is_png "$T/body"
check max_work_counted "$(metric 'rayd_rejections_total{reason="over_budget"}')" \
    metric_is 'rayd_rejections_total{reason="over_budget"}' 2

# tiles sized by cost: the same pixels as rayd-render's
code=$(post_json /v1/render "$T/cb_small.json")
cp "$T/body" "$T/server.png"
"$RENDER" "$T/cb_small.json" -o "$T/cli.png" --threads 2 2>/dev/null
check cost_tiles_same_pixels "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/server.png' '$T/cli.png'"
code=$(post_json /v1/jobs "$T/cb_small.json" -H 'X-Unused: 1')
id=$(jfield "$T/body" id)
side=$(tile_side "$(estimate "$T/cb_small.json")" 1600)
n=$(( ((40 + side - 1) / side) * ((40 + side - 1) / side) ))
wait_until 120 job_state_is "$id" succeeded
check cost_tiles_count "side $side: want $n tiles, $(head -c 300 "$T/body")" \
    bash -c "[ $side -lt 64 ] && [ '$(jfield "$T/body" tiles_total)' = $n ]"
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- fair shares between clients -------------------------------------------------------------
start_rayd --threads 1 --test-gate 0 --client-header X-Client
ids=()
for k in 1 2 3 4; do
    scene "$T/a$k.json" 320 240 1 spheres "$k"
    post_json /v1/jobs "$T/a$k.json" -H 'X-Client: alice' >/dev/null
    ids+=("$(jfield "$T/body" id)")
done
scene "$T/b.json" 320 240 1 spheres 9
post_json /v1/jobs "$T/b.json" -H 'X-Client: bob' >/dev/null
bob=$(jfield "$T/body" id)
wait_until 60 gate_is queued 5
gate 6 # alice's oldest first (the older), then bob, alice, bob, ...
job_done() { job_is "$1" tiles_done "$2"; }
wait_until 60 job_done "$bob" 3
check fair_turns_bob "bob's job has $(jfield "$T/body" tiles_done) of 6 tiles" job_done "$bob" 3
wait_until 60 job_done "${ids[0]}" 3
check fair_turns_alice "alice's oldest job has $(jfield "$T/body" tiles_done) of 6" \
    job_done "${ids[0]}" 3
check fair_alice_others_wait "alice's second job: $(head -c 200 "$T/body")" \
    job_done "${ids[1]}" 0
check queue_wait_by_class "$(metric 'rayd_queue_wait_seconds_count{class="bulk"}')" \
    metric_is 'rayd_queue_wait_seconds_count{class="bulk"}' 2
for id in "${ids[@]}" "$bob"; do req DELETE "/v1/jobs/$id" >/dev/null; done
gate open
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- one client's flood cannot fill the queue: its last quarter is kept for the others --------
start_rayd --threads 1 --test-gate 0 --client-header X-Client --queue 8
codes=""
for k in $(seq 1 7); do
    scene "$T/q$k.json" 8 8 1 spheres "$((k + 40))"
    codes="$codes $(post_json /v1/jobs "$T/q$k.json" -H 'X-Client: alice')"
done
check queue_flood_capped "alice's codes:$codes" [ "$codes" = " 202 202 202 202 202 202 503" ]
check queue_flood_says_why "$(head -c 300 "$T/body")" bash -c \
    "grep -q '\"code\":\"queue_full\"' '$T/body' && grep -q 'kept for clients with few renders queued' '$T/body'"
scene "$T/qb.json" 8 8 1 spheres 51
scene "$T/qc.json" 8 8 1 spheres 52
scene "$T/qd.json" 8 8 1 spheres 53
codes="$(post_json /v1/jobs "$T/qb.json" -H 'X-Client: bob') $(post_json /v1/jobs "$T/qc.json" -H 'X-Client: carol')"
codes="$codes $(post_json /v1/jobs "$T/qd.json" -H 'X-Client: dave')"
check queue_kept_for_others "bob, carol, dave: $codes" [ "$codes" = "202 202 503" ]
check queue_then_full "$(head -c 300 "$T/body")" bash -c "grep -q 'the render queue is full' '$T/body'"
gate open
stop_rayd

# --- the backlog: /readyz, metrics, Retry-After -----------------------------------------------
# No tile ever starts here, so the seconds are those of the starting rate.
start_rayd --threads 1 --test-gate 0 --queue 16 --max-backlog 2
code=$(post_json /v1/jobs "$T/cb.json")
e1=$(json "$T/body" 'j["estimate"]["seconds"]')
jobs=("$(jfield "$T/body" id)")
code=$(req GET /readyz)
check readyz_backlog_503 "status $code, estimate $e1 s: $(head -c 300 "$T/body")" \
    bash -c "[ $code = 503 ] && python3 -c 'import sys; sys.exit(not $e1 > 2)'"
check readyz_backlog_code "$(head -c 300 "$T/body")" err_is "$T/body" 503 backlog
check readyz_retry_after "Retry-After '$(header Retry-After)', estimate $e1" \
    bash -c "[ '$(header Retry-After)' = '$(ceil_div "$(python3 -c "print($e1 - 2)")" 1)' ]"
check backlog_metric "rayd_backlog_seconds $(metric rayd_backlog_seconds), estimate $e1" \
    python3 -c "import sys; sys.exit(not abs($(metric rayd_backlog_seconds) - $e1) < 0.01)"
for k in $(seq 2 16); do
    scene "$T/cb$k.json" 320 240 64 cornell "$k"
    post_json /v1/jobs "$T/cb$k.json" >/dev/null
    jobs+=("$(jfield "$T/body" id)")
done
code=$(post_json /v1/render "$T/paper.json")
check queue_full_retry_after "status $code, Retry-After '$(header Retry-After)', estimate $e1 s a job" \
    bash -c "[ $code = 503 ] && [ '$(header Retry-After)' = '$(ceil_div "$e1" 1)' ]"
for id in "${jobs[@]}"; do req DELETE "/v1/jobs/$id" >/dev/null; done
code=$(req GET /readyz)
check readyz_ready_again "status $code: $(head -c 200 "$T/body")" [ "$code" = 200 ]
gate open
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- the worker on a long tile: an 8x8 preview still gets one --------------------------------
# A pixel of a 28-deep stack of glass is 2^29 rays, more than any tile size can split: with the
# only worker on it, an 8x8 render of another client waited until --max-render-seconds.  The
# spare worker takes a quick interactive tile once every worker has been on its tile a while.
python3 - "$T/stack.json" <<'PY'
import json, sys
planes = [{"type": "plane", "point": [0, 0, z], "normal": [0, 0, 1], "material": "g"}
          for z in range(-10, 11)]
json.dump({"render": {"width": 1, "height": 1, "max_depth": 28},
           "camera": {"position": [0, 0, 0.5], "look_at": [1, 1, 1.5]},
           "materials": {"g": {"transparency": 0.5, "reflectivity": 0.5, "ior": 1.5}},
           "objects": planes}, open(sys.argv[1], "w"))
PY
start_rayd --threads 1 --max-render-seconds 120
curl -s -m 150 -o /dev/null -H 'Content-Type: application/json' --data-binary @"$T/stack.json" \
    "$URL/v1/render" &
stack_curl=$!
worker_busy() { [ "$(metric rayd_workers_busy)" = 1 ]; }
wait_until 30 worker_busy
scene "$T/preview.json" 8 8 1 spheres
code=$(post_json /v1/render "$T/preview.json" -m 60)
long=$(kill -0 "$stack_curl" 2>/dev/null && echo running || echo ended)
check preview_beside_long_tile "status $code, the long render $long" \
    bash -c "[ $code = 200 ] && [ $long = running ]"
kill "$stack_curl" 2>/dev/null # the client gone: its render is cancelled
wait "$stack_curl" 2>/dev/null
stop_rayd
check rayd_exit_0_spare "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]
