#!/usr/bin/env bash
# cluster_passes.sh -- progressive jobs on a cluster (rayd --redis): each
# pass's tiles rendered by any node as exact sums, each pass assembled once.
#
# A real redis-server on a free loopback port (lib/redis.sh) and three
# nodes.  Checks that a progressive job posted on one node is answered by
# the others with a single node's JSON keys; that every kept pass's PNG is
# byte for byte rayd-render's at that pass's samples (the pass rule) and
# the final image too; that the pass events replay from any node; that the
# stop rules end the job at the pass a single node stops at (noise target,
# time budget) and POST /v1/jobs/{id}/stop from any node keeps the latest
# pass, or ends the job after its first (the test gate, --test-gate 0,
# holds tiles so no sleep decides anything); that a node killed -9 mid-pass
# and sums stored corrupt or lost change no byte; that no sums are left in
# Redis; and the hostile cases: what such a job cannot keep (EXR, AOV,
# denoised passes), ?pass= out of range or not a number, stop of a plain
# job.  Every process is stopped by its PID.
source "$(dirname "$0")/lib/common.sh"
source "$(dirname "$0")/lib/redis.sh"

JSON=(-H 'Content-Type: application/json')
mk_scene() { # OUT SAMPLES [WIDTH]: the Cornell box at 96x64 (or WIDTHx64) with that many samples
    python3 -c 'import json,sys
d = json.load(open(sys.argv[1]))
d["render"].update(width=int(sys.argv[4]), height=64, samples=int(sys.argv[3]))
json.dump(d, open(sys.argv[2], "w"))' "$RAYD_ROOT/scenes/cornell.json" "$1" "$2" "${3:-96}"
}
SCENE=$T/c16.json
mk_scene "$SCENE" 16
for s in 1 2 4 8 16; do mk_scene "$T/c$s.json" $s; "$RENDER" "$T/c$s.json" -o "$T/ref$s.png" 2>/dev/null; done
post() { # NODE QUERY NAME [SCENE]: the status; the body in $T/NAME.json
    curl -s -m 30 -o "$T/$3.json" -w '%{http_code}' "${JSON[@]}" \
        --data-binary @"${4:-$SCENE}" "${NODE_URL[$1]}/v1/jobs?$2"
}
id_of() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1])).get("id", ""))' "$1" 2>/dev/null; }
ended() { case "$(job_state "${NODE_URL[$1]}" "$2")" in succeeded|failed|canceled) return 0;; esac; return 1; }
field() { # NODE ID PYEXPR: a value of the job's JSON (d)
    curl -s -m 30 "${NODE_URL[$1]}/v1/jobs/$2" | python3 -c "import json,sys; d=json.load(sys.stdin); print($3)" 2>/dev/null
}
gate_node() { curl -s -m 30 -X POST -o /dev/null "${NODE_URL[$1]}/v1/test/gate?tiles=$2"; }
sums_left() { rcli --scan --pattern "rayd:{$1}:sums:*" | wc -l; echo +; rcli --scan --pattern "rayd:{$1}:run:*" | wc -l; }

start_redis
for i in 1 2 3; do
    start_node $i --threads 1 --redis "$REDIS_URL" --cluster-tile 32 --redis-claim-ms 1500
done
wait_until 30 bash -c "curl -s '${NODE_URL[3]}/healthz' | grep -q '\"nodes\":3'"

# --- a progressive job: posted on 1, answered by 2 and 3 ------------------------------------
code=$(post 1 "progressive=1" p)
ID=$(id_of "$T/p.json")
check post_202 "POST gave $code: $(head -c 300 "$T/p.json")" [ "$code" = 202 -a -n "$ID" ]
wait_until 60 ended 2 "$ID"
check succeeded_on_2 "state: $(job_state "${NODE_URL[2]}" "$ID")" [ "$(job_state "${NODE_URL[2]}" "$ID")" = succeeded ]
check passes_json "passes: $(field 3 "$ID" 'd.get("passes")')" \
    [ "$(field 3 "$ID" '[d["passes"][k] for k in ("done","total","samples","samples_target","stopped_by")]')" = "[5, 5, 16, 16, None]" ]
curl -s -o "$T/final.png" "${NODE_URL[3]}/v1/jobs/$ID/image.png"
check final_byte_identical "the job's image differs from rayd-render's at 16 samples" cmp -s "$T/final.png" "$T/ref16.png"
pass_as_render() { # NODE ID K SAMPLES: pass K's PNG is rayd-render's at SAMPLES, with its headers
    curl -s -D "$T/pass$3.h" -o "$T/pass$3.png" "${NODE_URL[$1]}/v1/jobs/$2/image.png?pass=$3"
    cmp -s "$T/pass$3.png" "$T/ref$4.png" && grep -qi "^x-rayd-pass: $3/5" "$T/pass$3.h" &&
        grep -qi "^x-rayd-samples: $4" "$T/pass$3.h"
}
check pass2_as_render "pass 2 differs or lacks its headers: $(cat "$T/pass2.h" 2>/dev/null | head -3)" pass_as_render 1 "$ID" 2 2
check pass3_as_render "pass 3 differs" pass_as_render 2 "$ID" 3 4
check pass4_as_render "pass 4 differs" pass_as_render 3 "$ID" 4 8
check pass5_as_render "pass 5 differs" pass_as_render 1 "$ID" 5 16
code=$(curl -s -o "$T/gone.json" -w '%{http_code}' "${NODE_URL[2]}/v1/jobs/$ID/image.png?pass=1")
check pass1_gone_410 "pass 1 (not among the latest 4) gave $code: $(cat "$T/gone.json")" \
    bash -c "[ $code = 410 ] && grep -q pass_gone '$T/gone.json'"
for q in 6 0 abc 1e1 99999999999; do
    code=$(curl -s -o "$T/q.json" -w '%{http_code}' "${NODE_URL[2]}/v1/jobs/$ID/image.png?pass=$q")
    check "pass_${q}_400" "?pass=$q gave $code: $(cat "$T/q.json")" \
        bash -c "[ $code = 400 ] && grep -q '\"parameter\":\"pass\"' '$T/q.json' && grep -q '1..5' '$T/q.json'"
done
code=$(curl -s -o "$T/q.json" -w '%{http_code}' "${NODE_URL[2]}/v1/jobs/$ID/image.png?pass=2&pass=3")
check pass_twice_400 "two ?pass= gave $code" bash -c "[ $code = 400 ] && grep -q 'more than once' '$T/q.json'"
check no_sums_left "sums and running sums left in Redis: $(sums_left "$ID" | tr '\n' ' ')" \
    [ "$(sums_left "$ID" | tr -d '\n')" = "0+0" ]
check pass_keys_expire "pass 5's PNG has no TTL: $(rcli ttl "rayd:{$ID}:pass:5")" [ "$(rcli ttl "rayd:{$ID}:pass:5")" -gt 0 ]

# --- its events, replayed from node 2 -----------------------------------------------------
timeout 30 curl -s -N "${NODE_URL[2]}/v1/jobs/$ID/events" >"$T/events.txt"
check pass_events "events: $(grep -A1 '^event: pass' "$T/events.txt" | head -c 600)" python3 -c '
import json, sys
lines = open(sys.argv[1]).read().split("\n")
ev = [json.loads(lines[i + 1][6:]) for i, l in enumerate(lines) if l == "event: pass"]
ok = [e["pass"] for e in ev] == [1, 2, 3, 4, 5] and [e["samples"] for e in ev] == [1, 2, 4, 8, 16]
ok = ok and all(e["passes"] == 5 and e["image_url"].endswith("pass=%d" % e["pass"]) for e in ev)
ok = ok and ev[0]["noise"] is None and all(e["noise"] > 0 for e in ev[1:]) and ev[-1]["progress"] == 1
ok = ok and "event: tile" not in lines  # a progressive job reports passes, as one node does
sys.exit(0 if ok and "data: {\"state\":\"succeeded\",\"progress\":1.0000,\"samples\":16}" in lines else 1)' "$T/events.txt"

# --- the same job on a single node: the same keys, the same stop rules ----------------------
start_node 9 --threads 1
keys() { python3 -c 'import json,sys; d=json.load(sys.stdin); print(" ".join(d), " ".join(d.get("passes", {})))'; }
SID=$(curl -s "${JSON[@]}" --data-binary @"$SCENE" "${NODE_URL[9]}/v1/jobs?progressive=1" | python3 -c 'import json,sys; print(json.load(sys.stdin)["id"])')
wait_until 60 ended 9 "$SID"
curl -s "${NODE_URL[9]}/v1/jobs/$SID" | keys >"$T/single.keys"
curl -s "${NODE_URL[2]}/v1/jobs/$ID" | keys >"$T/cluster.keys"
check same_keys_as_single_node "single: $(cat "$T/single.keys") / cluster: $(cat "$T/cluster.keys")" cmp -s "$T/single.keys" "$T/cluster.keys"
stop_rule() { # NAME QUERY WHY: the cluster stops where the single node stops, for WHY
    local cid sid c s
    post 1 "progressive=1&$2" "$1" >/dev/null; cid=$(id_of "$T/$1.json")
    post 9 "progressive=1&$2" "$1s" >/dev/null; sid=$(id_of "$T/$1s.json")
    wait_until 60 ended 3 "$cid"; wait_until 60 ended 9 "$sid"
    c=$(field 3 "$cid" '[d["state"], d["passes"]["done"], d["passes"]["samples"], d["passes"]["stopped_by"]]')
    s=$(field 9 "$sid" '[d["state"], d["passes"]["done"], d["passes"]["samples"], d["passes"]["stopped_by"]]')
    curl -s -o "$T/$1.png" "${NODE_URL[2]}/v1/jobs/$cid/image.png"
    curl -s -o "$T/$1s.png" "${NODE_URL[9]}/v1/jobs/$sid/image.png"
    check "$1" "cluster: $c, single node: $s" bash -c "[ \"$c\" = \"$s\" ] && [[ \"$c\" == *\"$3\" ]] && cmp -s '$T/$1.png' '$T/$1s.png'"
}
stop_rule noise_target_as_single "noise_target=0.2" "'noise_target']"
stop_rule time_budget_as_single "time_budget=0.001" "'time_budget']"
stop_rule pass_step_as_single "pass_step=5" "16, None]"
kill -KILL "${NODE_PID[9]}"

# --- hostile: what a cluster's progressive job cannot keep, stop of a plain job -------------
refused() { # NAME QUERY PARAM: 400 naming progressive, and PARAM in its message
    local code
    code=$(post 2 "$2" "$1")
    check "$1" "gave $code: $(head -c 300 "$T/$1.json")" bash -c "[ $code = 400 ] && grep -q '\"parameter\":\"progressive\"' '$T/$1.json' && grep -q 'keeps a progressive job.s passes as PNGs of the light alone, so not with $3' '$T/$1.json'"
}
refused refuse_progressive_exr "progressive=1&format=exr" format
refused refuse_progressive_aov "progressive=1&aov=normal" aov
refused refuse_progressive_denoise "progressive=1&denoise=1" denoise
code=$(post 2 "progressive=1" anim "$RAYD_ROOT/scenes/animation.json")
check refuse_progressive_frames "gave $code: $(head -c 300 "$T/anim.json")" \
    bash -c "[ $code = 400 ] && grep -q 'a frame-range job is not progressive' '$T/anim.json'"
post 3 "" plain >/dev/null
PID_PLAIN=$(id_of "$T/plain.json")
code=$(curl -s -o "$T/stop.json" -w '%{http_code}' -X POST "${NODE_URL[1]}/v1/jobs/$PID_PLAIN/stop")
check stop_plain_409 "stop of a plain job gave $code: $(cat "$T/stop.json")" bash -c "[ $code = 409 ] && grep -q not_progressive '$T/stop.json'"
code=$(curl -s -o "$T/stop.json" -w '%{http_code}' -X POST "${NODE_URL[1]}/v1/jobs/0123456789abcdef0123456789abcdef/stop")
check stop_unknown_404 "stop of no job gave $code" [ "$code" = 404 ]

# --- kill -9 a node mid-pass, sums corrupt or lost: the same bytes -------------------------
wait_until 60 ended 3 "$PID_PLAIN" # no item of another job is left for the nodes below
for i in 1 2 3; do kill -KILL "${NODE_PID[$i]}"; done
# node 4 takes an item of pass 1 and holds it (its gate lets no tile start): killed -9, its
# item is taken over by node 5, then the only node, which stores its first tile's sums corrupt
# (alone, so no duplicate of that tile can overwrite them before the assembly sees them)
start_node 4 --threads 1 --redis "$REDIS_URL" --cluster-tile 32 --redis-claim-ms 1500 --test-gate 0
code=$(post 4 "progressive=1" f)
FID=$(id_of "$T/f.json")
wait_until 30 bash -c "[ \"\$(curl -s '${NODE_URL[4]}/metrics' | awk '\$1 == \"rayd_cluster_node_items_in_flight\" {print \$2}')\" = 1 ]"
kill -KILL "${NODE_PID[4]}"
RAYD_TEST_CLUSTER_TILE=corrupt start_node 5 --threads 1 --redis "$REDIS_URL" --cluster-tile 32 --redis-claim-ms 1500 --test-gate open
wait_until 90 ended 5 "$FID"
curl -s -o "$T/faults.png" "${NODE_URL[5]}/v1/jobs/$FID/image.png"
check faults_byte_identical "state $(job_state "${NODE_URL[5]}" "$FID"); the image differs from rayd-render's" \
    bash -c "cmp -s '$T/faults.png' '$T/ref16.png'"
check faults_took_over "node 5 took over nothing" grep -q 'took over item' "$T/node5.err"
check faults_corrupt_rerendered "node 5 did not say a tile's sums were corrupt: $(grep -E 'warn|took' "$T/node5.err" | head -6)" \
    grep -q "sums missing or corrupt in Redis" "$T/node5.err"
check faults_no_sums_left "left: $(sums_left "$FID" | tr '\n' ' ')" [ "$(sums_left "$FID" | tr -d '\n')" = "0+0" ]

# --- POST stop from any node: the latest pass kept, or the first pass ends it ----------------
start_node 7 --threads 1 --redis "$REDIS_URL" --cluster-tile 32 --test-gate 0
kill -KILL "${NODE_PID[5]}"
post 7 "progressive=1" s1 >/dev/null
S1=$(id_of "$T/s1.json")
gate_node 7 6 # pass 1's six tiles, and no more
wait_until 60 bash -c "[ \"\$(curl -s '${NODE_URL[7]}/v1/jobs/$S1' | python3 -c 'import json,sys; print(json.load(sys.stdin)[\"passes\"][\"done\"])')\" = 1 ]"
code=$(curl -s -o "$T/stop1.json" -w '%{http_code}' -X POST "${NODE_URL[7]}/v1/jobs/$S1/stop")
check stop_keeps_latest_pass "stop gave $code: $(head -c 400 "$T/stop1.json")" python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
sys.exit(0 if sys.argv[2] == "200" and d["state"] == "succeeded" and d["passes"]["done"] == 1
         and d["passes"]["stopped_by"] == "client" else 1)' "$T/stop1.json" "$code"
curl -s -D "$T/s1.h" -o "$T/s1.png" "${NODE_URL[7]}/v1/jobs/$S1/image.png"
check stop_no_sums_left "left: $(sums_left "$S1" | tr '\n' ' ')" [ "$(sums_left "$S1" | tr -d '\n')" = "0+0" ]
check stopped_image_is_pass1 "the image is not pass 1's: $(head -3 "$T/s1.h")" bash -c "cmp -s '$T/s1.png' '$T/ref1.png' && grep -qi '^x-rayd-pass: 1/5' '$T/s1.h'"
mk_scene "$T/s2.json" 16 93 # none of its tiles cached: the stop comes before its first pass
post 7 "progressive=1" s2 "$T/s2.json" >/dev/null
S2=$(id_of "$T/s2.json")
code=$(curl -s -o "$T/stop2.json" -w '%{http_code}' -X POST "${NODE_URL[7]}/v1/jobs/$S2/stop")
gate_node 7 open
wait_until 60 ended 7 "$S2"
check stop_said_at_once "the stop's answer: $(head -c 500 "$T/stop2.json")" \
    grep -q '"stopped_by":"client"' "$T/stop2.json"
check stop_before_first_pass "stop gave $code; then: $(field 7 "$S2" '[d["state"], d["passes"]]')" \
    [ "$code" = 200 -a "$(field 7 "$S2" '[d["state"], d["passes"]["done"], d["passes"]["stopped_by"]]')" = "['succeeded', 1, 'client']" ]
code=$(curl -s -o "$T/stop3.json" -w '%{http_code}' -X POST "${NODE_URL[7]}/v1/jobs/$S2/stop")
check stop_again_200 "a second stop gave $code" [ "$code" = 200 ]

# --- a tile's running sums lost between passes: it renders all its samples again ---------------
gate_node 7 0
mk_scene "$T/lost.json" 16 95 # a scene of its own: no tile of it is in the result cache
"$RENDER" "$T/lost.json" -o "$T/lost_ref.png" 2>/dev/null
post 7 "progressive=1" r "$T/lost.json" >/dev/null
RID=$(id_of "$T/r.json")
gate_node 7 12 # passes 1 and 2
wait_until 60 bash -c "[ \"\$(rcli hget 'rayd:{$RID}:job' passes_done)\" = 2 ]"
rcli del "rayd:{$RID}:run:2:3" >/dev/null
gate_node 7 open
wait_until 60 ended 7 "$RID"
curl -s -o "$T/lost.png" "${NODE_URL[7]}/v1/jobs/$RID/image.png"
check lost_run_byte_identical "state $(job_state "${NODE_URL[7]}" "$RID"); the image differs from rayd-render's" cmp -s "$T/lost.png" "$T/lost_ref.png"
check lost_run_rendered_whole "node 7 did not say so: $(grep 'rendered again' "$T/node7.err" | head -2)" \
    grep -q "pass 3: 1 tile(s)' sums missing or corrupt in Redis (first: 3), rendered again; 1 of them lost" "$T/node7.err"

# --- DELETE mid-job: cancelled, no sums left ----------------------------------------------------
gate_node 7 0
mk_scene "$T/del.json" 16 94
post 7 "progressive=1" d "$T/del.json" >/dev/null
DID=$(id_of "$T/d.json")
gate_node 7 8 # pass 1, and two tiles of pass 2
wait_until 60 bash -c "[ \"\$(rcli hget 'rayd:{$DID}:job' tiles_done)\" = 2 ] && [ \"\$(rcli hget 'rayd:{$DID}:job' pass)\" = 2 ]"
code=$(curl -s -o "$T/del.json" -w '%{http_code}' -X DELETE "${NODE_URL[7]}/v1/jobs/$DID")
check delete_cancels "DELETE gave $code: $(head -c 200 "$T/del.json")" bash -c "[ $code = 200 ] && grep -q '\"state\":\"canceled\"' '$T/del.json'"
check delete_no_sums_left "left: $(sums_left "$DID" | tr '\n' ' ')" [ "$(sums_left "$DID" | tr -d '\n')" = "0+0" ]
code=$(curl -s -o "$T/dimg.json" -w '%{http_code}' "${NODE_URL[7]}/v1/jobs/$DID/image.png")
check canceled_image_409 "image.png gave $code: $(head -c 200 "$T/dimg.json")" bash -c "[ $code = 409 ] && grep -q job_canceled '$T/dimg.json'"
code=$(curl -s -o "$T/dimg.json" -w '%{http_code}' "${NODE_URL[7]}/v1/jobs/$DID/image.png?pass=1")
check canceled_pass_410 "image.png?pass=1 gave $code: $(head -c 200 "$T/dimg.json")" bash -c "[ $code = 410 ] && grep -q pass_gone '$T/dimg.json'"
gate_node 7 open

[ "$NFAIL" = 0 ]
