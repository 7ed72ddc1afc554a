#!/usr/bin/env bash
# cluster_limits.sh -- rayd --redis keeps a single node's limits and
# counters: --max-jobs counted cluster-wide (503 queue_full with
# Retry-After, as one node's full table; two nodes racing for the last
# place let one job in), an expired job answers 410 job_expired from any
# node (its tombstone, rayd:{ID}:gone) while an id never made is 404, a
# job's rays are the sum of its tiles' and equal a single node's job of the
# same frame (tiles from the result cache count what they cost), and a frame's assembly is charged to the node's --max-memory:
# a node without room leaves it for another (the job never fails), and a
# frame no node of that budget could assemble is refused at POST (413).
#
# A real redis-server on a free loopback port (lib/redis.sh); the test gate
# (--test-gate 0) holds jobs unfinished, with no sleep deciding anything.
# Every process is stopped by its PID.
source "$(dirname "$0")/lib/common.sh"
source "$(dirname "$0")/lib/redis.sh"

SCENE=$RAYD_ROOT/scenes/spheres.json
JSON=(-H 'Content-Type: application/json')
REG='x=64&y=64&w=256&h=192' # 12 tiles of 64
gate_node() { curl -s -m 30 -X POST -o /dev/null "${NODE_URL[$1]}/v1/test/gate?tiles=$2"; }
post() { # NODE QUERY NAME: the status; the body in $T/NAME.json, headers in $T/NAME.h
    curl -s -m 30 -o "$T/$3.json" -D "$T/$3.h" -w '%{http_code}' "${JSON[@]}" \
        --data-binary @"$SCENE" "${NODE_URL[$1]}/v1/jobs?$2"
}
id_of() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1])).get("id", ""))' "$1" 2>/dev/null; }
succeeded() { [ "$(job_state "${NODE_URL[$1]}" "$2")" = succeeded ]; }
# NODE ID FILE: the job's JSON into FILE, and whether it says succeeded (read in one
# request: a job here is forgotten 5 s after it ends, --job-ttl 5)
succeeded_into() { curl -s -o "$3" "${NODE_URL[$1]}/v1/jobs/$2" && grep -q '"state":"succeeded"' "$3"; }
retry_after() { grep -i '^retry-after: *[1-9]' "$1" >/dev/null; }

start_redis
VERSION=$("$RAYD" --version | awk '{print $2}')

# --- --max-jobs counts the cluster's unfinished jobs -------------------------------------
for i in 1 2; do
    start_node $i --threads 1 --cluster-tile 64 --max-jobs 2 --job-ttl 5 --test-gate 0 --redis "$REDIS_URL"
done
c1=$(post 1 "$REG" a)
A=$(id_of "$T/a.json")
c2=$(post 2 "$REG" b)
B=$(id_of "$T/b.json")
check max_jobs_room "POSTs gave $c1 $c2" [ "$c1" = 202 -a "$c2" = 202 ]
c3=$(post 1 "$REG" c1)
check max_jobs_full_503 "gave $c3: $(head -c 300 "$T/c1.json")" bash -c \
    "[ $c3 = 503 ] && grep -q '\"code\":\"queue_full\"' '$T/c1.json' && grep -q 'too many unfinished jobs' '$T/c1.json'"
check max_jobs_retry_after "headers: $(tr -d '\r' <"$T/c1.h" | tr '\n' ' ')" retry_after "$T/c1.h"
c4=$(post 2 "$REG" c2)
check max_jobs_cluster_wide "node 2 gave $c4 (node 1 holds one job, node 2 one)" [ "$c4" = 503 ]
check max_jobs_nothing_written "jobs in Redis: $(listed_jobs)" [ "$(listed_jobs)" = 2 ]
# /readyz says so on every node, as a single node with a full table does
readyz_full() {
    curl -s -o "$T/ready$1.json" "${NODE_URL[$1]}/readyz"
    grep -q '"jobs":2,"max_jobs":2,"jobs_refused":"all 2 jobs kept (--max-jobs) are unfinished in the cluster' "$T/ready$1.json"
}
wait_until 30 readyz_full 1
check max_jobs_readyz "node 1: $(cat "$T/ready1.json")" readyz_full 1
# the same answer as a single node's full table
start_node 9 --threads 1 --max-jobs 1 --test-gate 0
curl -s -o /dev/null "${JSON[@]}" --data-binary @"$SCENE" "${NODE_URL[9]}/v1/jobs?$REG"
curl -s -o "$T/single503.json" "${JSON[@]}" --data-binary @"$SCENE" "${NODE_URL[9]}/v1/jobs?$REG"
check max_jobs_same_as_single_node "single: $(cat "$T/single503.json") cluster: $(cat "$T/c1.json")" \
    cmp -s "$T/single503.json" "$T/c1.json"
kill -KILL "${NODE_PID[9]}"
# one place left, two nodes race for it: exactly one job gets in
curl -s -o /dev/null -X DELETE "${NODE_URL[2]}/v1/jobs/$A"
post 1 "$REG" r1 >"$T/r1.code" &
p1=$!
post 2 "$REG" r2 >"$T/r2.code" &
wait "$p1" "$!"
check max_jobs_race_one_wins "gave $(cat "$T/r1.code") and $(cat "$T/r2.code")" bash -c \
    "[ \"\$(sort '$T/r1.code' '$T/r2.code' | tr '\n' ' ')\" = '202 503 ' ]"
check max_jobs_unfinished_set "rayd:unfinished holds $(rcli scard rayd:unfinished)" [ "$(rcli scard rayd:unfinished)" = 2 ]
# every job ended: ids left in the set by hand (a job Redis lost) do not block
for id in $(rcli smembers rayd:unfinished); do curl -s -o /dev/null -X DELETE "${NODE_URL[1]}/v1/jobs/$id"; done
rcli sadd rayd:unfinished ffffffffffffffffffffffffffffffff eeeeeeeeeeeeeeeeeeeeeeeeeeeeeeee >/dev/null
c5=$(post 1 "$REG" rays) # held at the gates until the wait below reads it
R=$(id_of "$T/rays.json")
check max_jobs_stale_ids_pruned "gave $c5: $(head -c 200 "$T/rays.json"); set: $(rcli smembers rayd:unfinished | tr '\n' ' ')" \
    bash -c "[ $c5 = 202 ] && ! rcli smembers rayd:unfinished | grep -q -e ffff -e eeee"

# --- a job's rays: its tiles' sum, a single node's figure ----------------------------------
for i in 1 2; do gate_node $i open; done
wait_until 120 succeeded_into 2 "$R" "$T/rays_job.json"
start_node 9 --threads 2
curl -s -o "$T/single.json" "${JSON[@]}" --data-binary @"$SCENE" "${NODE_URL[9]}/v1/jobs?$REG"
S=$(id_of "$T/single.json")
wait_until 120 bash -c "curl -s '${NODE_URL[9]}/v1/jobs/$S' | grep -q '\"state\":\"succeeded\"'"
curl -s "${NODE_URL[9]}/v1/jobs/$S" >"$T/single_job.json"
cr=$(json "$T/rays_job.json" 'j["rays"]')
sr=$(json "$T/single_job.json" 'j["rays"]')
check job_rays_single_node "cluster job: $cr rays, single node's: $sr" [ -n "$cr" -a "$cr" = "$sr" -a "${cr:-0}" != 0 ]
# the same frame again: every tile from the nodes' result caches, the same rays
post 2 "$REG" again >/dev/null
R2=$(id_of "$T/again.json")
wait_until 120 succeeded_into 1 "$R2" "$T/again_job.json"
cr2=$(json "$T/again_job.json" 'j["rays"]')
check job_rays_from_result_cache "cluster job again: $cr2 rays, single node's: $sr" [ "$cr2" = "$sr" ]
check job_encode_ms "encode_ms: $(json "$T/rays_job.json" 'j["encode_ms"]')" \
    python3 -c 'import json,sys; sys.exit(0 if json.load(open(sys.argv[1]))["encode_ms"] > 0 else 1)' "$T/rays_job.json"
kill -KILL "${NODE_PID[9]}"

# --- an expired job: 410 job_expired from any node; an id never made: 404 -------------------
gone() { [ "$(curl -s -o /dev/null -w '%{http_code}' "${NODE_URL[$1]}/v1/jobs/$2")" = 410 ]; }
wait_until 30 gone 1 "$R"
code=$(curl -s -o "$T/gone.json" -D "$T/gone.h" -w '%{http_code}' "${NODE_URL[1]}/v1/jobs/$R")
check expired_410 "gave $code: $(head -c 300 "$T/gone.json")" bash -c \
    "[ $code = 410 ] && grep -q '\"code\":\"job_expired\"' '$T/gone.json' && grep -q '\"state\":\"succeeded\"' '$T/gone.json' && grep -q 'kept for --job-ttl 5 s' '$T/gone.json'"
check expired_no_store "headers: $(tr -d '\r' <"$T/gone.h" | tr '\n' ' ')" grep -qi '^cache-control: no-store' "$T/gone.h"
for path in image.png events; do
    code=$(curl -s -m 30 -o "$T/gone_$path" -w '%{http_code}' "${NODE_URL[2]}/v1/jobs/$R/$path")
    check "expired_${path%%.*}_410" "gave $code: $(head -c 200 "$T/gone_$path")" bash -c \
        "[ $code = 410 ] && grep -q job_expired '$T/gone_$path'"
done
check expired_tombstone_ttl "rayd:{$R}:gone ttl $(rcli ttl "rayd:{$R}:gone")" [ "$(rcli ttl "rayd:{$R}:gone")" -gt 80000 ]
check expired_keys_gone "keys left: $(rcli --scan --pattern "rayd:{$R}:*" | tr '\n' ' ')" \
    [ "$(rcli --scan --pattern "rayd:{$R}:*")" = "rayd:{$R}:gone" ]
code=$(curl -s -o "$T/unknown.json" -w '%{http_code}' "${NODE_URL[2]}/v1/jobs/0123456789abcdef0123456789abcdef")
check unknown_id_404 "gave $code: $(cat "$T/unknown.json")" bash -c "[ $code = 404 ] && grep -q job_unknown '$T/unknown.json'"
# the same keys as a single node's 410
start_node 9 --threads 1 --job-ttl 1
curl -s -o "$T/s.json" "${JSON[@]}" --data-binary @"$SCENE" "${NODE_URL[9]}/v1/jobs?$REG"
S=$(id_of "$T/s.json")
wait_until 60 gone 9 "$S"
curl -s -o "$T/single_gone.json" "${NODE_URL[9]}/v1/jobs/$S"
ekeys() { python3 -c 'import json,sys; print(list(json.load(open(sys.argv[1]))["error"]))' "$1"; }
check expired_same_keys_as_single_node "single: $(cat "$T/single_gone.json") cluster: $(cat "$T/gone.json")" \
    [ "$(ekeys "$T/single_gone.json")" = "$(ekeys "$T/gone.json")" ]
code=$(curl -s -o "$T/list.json" -w '%{http_code}' "${NODE_URL[1]}/v1/jobs")
check expired_not_listed "list: $(head -c 300 "$T/list.json")" bash -c "[ $code = 200 ] && ! grep -q '$R' '$T/list.json'"
kill -KILL "${NODE_PID[9]}" "${NODE_PID[1]}" "${NODE_PID[2]}"

# --- a frame's assembly is charged to --max-memory ---------------------------------------------
# node 4's budget (at least 1M) renders a 128 px tile but cannot hold the
# 512 x 384 frame (~1.2 MB); node 3 takes the POST and dies; node 4 renders
# every tile and leaves the assembly, which node 5 (room enough) takes over.
AREG='x=64&y=64&w=512&h=384'
NEED=$((512 * 384 * 6 + 128 * 128 * 3 + 4096))
# Node 4 takes the assembly back every --redis-claim-ms and counts a miss each time: past 20 the
# job fails (no node with room).  Its 4 s give node 5 (1.5 s, which takes it over once idle for
# that long) 80 s to start on a loaded machine; at 1.5 s both, a node 5 slow to start lost the job.
SMALL=(--threads 1 --cluster-tile 128 --redis-claim-ms 4000 --max-memory $((NEED - 8192)))
start_node 4 "${SMALL[@]}" --redis "$REDIS_URL"
start_node 3 --threads 1 --cluster-tile 128 --redis-claim-ms 1500 --test-gate 0 --redis "$REDIS_URL"
code=$(post 3 "$AREG" asm)
M=$(id_of "$T/asm.json")
kill -KILL "${NODE_PID[3]}"
deferred() { [ "$(metric 4 rayd_cluster_assemblies_deferred_total)" -ge 1 ]; }
wait_until 120 deferred
check assembly_deferred "POST $code; rayd_cluster_assemblies_deferred_total $(metric 4 rayd_cluster_assemblies_deferred_total); $(grep -m1 'assembly needs' "$T/node4.err")" \
    bash -c "deferred() { [ \"\$(curl -s '${NODE_URL[4]}/metrics' | awk '\$1 == \"rayd_cluster_assemblies_deferred_total\" {print \$2}')\" -ge 1 ]; }; deferred && grep -q 'its assembly needs $NEED bytes' '$T/node4.err'"
curl -s "${NODE_URL[4]}/v1/jobs/$M" >"$T/asm_job.json"
check assembly_job_not_failed "$(head -c 300 "$T/asm_job.json")" bash -c \
    "grep -q '\"state\":\"running\"' '$T/asm_job.json' && grep -q '\"tiles_done\":12' '$T/asm_job.json'"
start_node 5 --threads 1 --cluster-tile 128 --redis-claim-ms 1500 --redis "$REDIS_URL"
wait_until 180 succeeded 5 "$M"
check assembly_taken_over "state: $(curl -s -m 30 "${NODE_URL[5]}/v1/jobs/$M" | head -c 600)" succeeded 4 "$M"
curl -s -o "$T/asm.png" "${NODE_URL[4]}/v1/jobs/$M/image.png"
"$RENDER" "$SCENE" --region 64,64,512,384 -o "$T/asm_ref.png" 2>/dev/null
check assembly_byte_identical "the frame differs from rayd-render --region's" cmp -s "$T/asm.png" "$T/asm_ref.png"
check small_node_alive "node 4 died: $(tail -n 3 "$T/node4.err")" kill -0 "${NODE_PID[4]}"

# a frame no live node can assemble: its POST passed on a node with room
# (3, gone), and node 7's whole budget is under the frame's need, so after
# 20 tries the job fails too_large, naming the need, instead of waiting for ever
kill -KILL "${NODE_PID[4]}" "${NODE_PID[5]}" # nodes with room would assemble it
start_node 7 --threads 1 --cluster-tile 128 --redis-claim-ms 400 --max-memory $((NEED - 8192)) --redis "$REDIS_URL"
start_node 3 --threads 1 --cluster-tile 128 --redis-claim-ms 400 --test-gate 0 --redis "$REDIS_URL"
code=$(post 3 "$AREG" never)
NV=$(id_of "$T/never.json")
kill -KILL "${NODE_PID[3]}"
ended() { case "$(job_state "${NODE_URL[7]}" "$NV")" in failed | succeeded) return 0 ;; esac; return 1; }
wait_until 120 ended
curl -s "${NODE_URL[7]}/v1/jobs/$NV" >"$T/never_job.json"
check assembly_never_fails "POST $code; $(grep -o "\"error\".*" "$T/never_job.json" | head -c 400)" bash -c \
    "grep -q '\"state\":\"failed\"' '$T/never_job.json' && grep -q '\"code\":\"too_large\"' '$T/never_job.json' && grep -q 'its assembly needs $NEED bytes' '$T/never_job.json'"
# node 7 took its own deferred assembly back each time: not a take-over from a stalled node
back=$(grep -c "took back item .*(job $NV frame 0 tile -1)" "$T/node7.err")
over=$(grep -c "took over item .*(job $NV frame 0 tile -1)" "$T/node7.err")
check assembly_taken_back_not_over "took back $back times, took over $over times" [ "$back" -ge 1 -a "$over" = 0 ]
kill -KILL "${NODE_PID[7]}"

# a frame no node of this budget could assemble: 413 at POST, as one node
# refuses the render (a 1280 x 960 PNG holds 7.4 MB; the budget, 6M, takes
# the scene's parse and little more)
python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); d["render"].update(width=1280, height=960); print(json.dumps(d))' "$SCENE" >"$T/wide.json"
start_node 6 --threads 1 --max-memory 6M --redis "$REDIS_URL"
start_node 9 --threads 1 --max-memory 6M
for i in 6 9; do
    curl -s -o "$T/toobig$i.json" -w '%{http_code}' "${JSON[@]}" --data-binary @"$T/wide.json" "${NODE_URL[$i]}/v1/jobs" >"$T/toobig$i.code"
done
check assembly_over_budget_413 "cluster node: $(cat "$T/toobig6.code") $(head -c 300 "$T/toobig6.json"); single node: $(cat "$T/toobig9.code") $(head -c 300 "$T/toobig9.json")" \
    bash -c "[ \"\$(cat '$T/toobig6.code')\" = 413 ] && cmp -s '$T/toobig6.json' '$T/toobig9.json' && grep -q '\"code\":\"over_memory\"' '$T/toobig6.json'"

[ "$NFAIL" = 0 ]
