#!/usr/bin/env bash
# cluster_items.sh -- rayd --redis: the streams of work items, one per
# priority, and the consumers of gone nodes.
#
# A real redis-server on a free loopback port (lib/redis.sh) and rayd nodes
# with --redis-claim-ms 1000 and the test gate.  Priority: one node with one
# worker holds the first item of a low job at its gate while a normal and a
# high job are queued behind it; once the gate opens the high job must end
# first, then the normal one, then the low one (their `ended` times in
# Redis, not wall time).  Gone nodes: a node killed -9 while it holds items
# loses them to the others (XAUTOCLAIM) and then, past the "gone" rule (3 x
# claim-ms), its consumer leaves the groups and its heartbeat rayd:nodes,
# removed by exactly one of the nodes left, while the live nodes stay; a
# node stopped cleanly removes its own consumer at once; nodes whose clocks
# are an hour off are still counted live by every node.
# Every process is stopped by its PID.
source "$(dirname "$0")/lib/common.sh"
source "$(dirname "$0")/lib/redis.sh"

SCENE=$RAYD_ROOT/scenes/spheres.json
JSON=(-H 'Content-Type: application/json')
VERSION=$("$RAYD" --version | awk '{print $2}')
STREAMS=("rayd:items:$VERSION:high" "rayd:items:$VERSION" "rayd:items:$VERSION:low")

gate_node() { curl -s -m 30 -X POST -o /dev/null "${NODE_URL[$1]}/v1/test/gate?tiles=$2"; }
post_job() { # NODE QUERY: the new job's id
    curl -s -m 30 "${JSON[@]}" --data-binary @"$SCENE" "${NODE_URL[$1]}/v1/jobs?$2" |
        python3 -c 'import json,sys; print(json.load(sys.stdin).get("id", ""))'
}
succeeded() { [ "$(job_state "${NODE_URL[$1]}" "$2")" = succeeded ]; }
holds() { [ "$(metric "$1" rayd_cluster_node_items_in_flight)" -ge "$2" ]; }
ended() { rcli hget "rayd:{$1}:job" ended; }
consumers() { # the consumer names of every stream's group
    local s
    for s in "${STREAMS[@]}"; do rcli xinfo consumers "$s" render 2>/dev/null | awk 'NR % 6 == 2'; done | sort -u
}

start_redis

# --- priority: high before normal before low, on one worker ----------------------------------
start_node 1 --threads 1 --cluster-tile 16 --redis-claim-ms 1000 --test-gate 0 --redis "$REDIS_URL"
REGION="x=0&y=0&w=64&h=64"
LOW=$(post_job 1 "$REGION&priority=low")
wait_until 30 holds 1 1
NORMAL=$(post_job 1 "$REGION")
HIGH=$(post_job 1 "$REGION&priority=high")
check priority_streams "items of low/normal/high: $(rcli xlen "${STREAMS[2]}")/$(rcli xlen "${STREAMS[1]}")/$(rcli xlen "${STREAMS[0]}")" \
    [ "$(rcli xlen "${STREAMS[0]}")" = 16 -a "$(rcli xlen "${STREAMS[1]}")" = 16 -a "$(rcli xlen "${STREAMS[2]}")" = 16 ]
wait_until 10 bash -c "[ \$(curl -s '${NODE_URL[1]}/metrics' | awk '\$1 == \"rayd_cluster_items_queued\" {print \$2}') = 47 ]"
check priority_queued_sums "rayd_cluster_items_queued $(metric 1 rayd_cluster_items_queued), in flight $(metric 1 rayd_cluster_items_in_flight)" \
    [ "$(metric 1 rayd_cluster_items_queued)" = 47 -a "$(metric 1 rayd_cluster_items_in_flight)" = 1 ]
check priority_in_json "$(curl -s "${NODE_URL[1]}/v1/jobs/$HIGH" | head -c 300)" \
    bash -c "curl -s '${NODE_URL[1]}/v1/jobs/$HIGH' | grep -q '\"priority\":\"high\"'"
gate_node 1 open
for id in "$LOW" "$NORMAL" "$HIGH"; do wait_until 60 succeeded 1 "$id"; done
all_succeeded() { succeeded 1 "$LOW" && succeeded 1 "$NORMAL" && succeeded 1 "$HIGH"; }
check priority_all_succeeded "states: $(job_state "${NODE_URL[1]}" "$LOW") $(job_state "${NODE_URL[1]}" "$NORMAL") $(job_state "${NODE_URL[1]}" "$HIGH")" \
    all_succeeded
h=$(ended "$HIGH") n=$(ended "$NORMAL") l=$(ended "$LOW")
in_order() { [ -n "$h" ] && [ -n "$n" ] && [ -n "$l" ] && [ "$h" -lt "$n" ] && [ "$n" -lt "$l" ]; }
check priority_high_first "ended (ms): high $h, normal $n, low $l" in_order
# a still job's events are the single node's: no "frame" event (its frame is image.png)
curl -s -N -m 10 "${NODE_URL[1]}/v1/jobs/$HIGH/events" >"$T/events.txt"
check still_job_events "$(grep '^event:' "$T/events.txt" | sort | uniq -c | tr '\n' ' ')" \
    bash -c "grep -q '^event: done' '$T/events.txt' && ! grep -q '^event: frame' '$T/events.txt'"
code=$(curl -s -o "$T/bad.json" -w '%{http_code}' "${JSON[@]}" --data-binary @"$SCENE" "${NODE_URL[1]}/v1/jobs?priority=urgent")
check priority_bad_400 "gave $code: $(head -c 200 "$T/bad.json")" bash -c "[ $code = 400 ] && grep -q priority '$T/bad.json'"

# --- a node killed -9: its items taken over, then its consumer and heartbeat removed ----------
gate_node 1 0
start_node 2 --threads 2 --cluster-tile 64 --redis-claim-ms 1000 --test-gate 0 --redis "$REDIS_URL"
ID=$(post_job 2 "priority=high")
wait_until 30 holds 2 2
check dead_node_holds "node 2 holds $(metric 2 rayd_cluster_node_items_in_flight) items" holds 2 2
DEAD="$(hostname):${NODE_URL[2]##*:}:${NODE_PID[2]}"
listed() { consumers | grep -qxF "$DEAD"; }
check dead_node_consumer_listed "consumers: $(consumers | tr '\n' ' ')" listed
kill -KILL "${NODE_PID[2]}"
wait "${NODE_PID[2]}" 2>/dev/null
start_node 3 --threads 2 --cluster-tile 64 --redis-claim-ms 1000 --redis "$REDIS_URL"
gate_node 1 open
wait_until 60 succeeded 3 "$ID"
check dead_node_job_finishes "state: $(job_state "${NODE_URL[3]}" "$ID")" succeeded 3 "$ID"
gone() { ! listed && [ -z "$(rcli hget rayd:nodes "$DEAD")" ]; }
wait_until 30 gone
check dead_node_consumer_removed "consumers: $(consumers | tr '\n' ' '); rayd:nodes: $(rcli hkeys rayd:nodes | tr '\n' ' ')" gone
removed=$(cat "$T/node1.err" "$T/node3.err" | grep -c "consumer $DEAD removed")
check dead_node_removed_once "removals logged: $removed" [ "$removed" = 1 ]
check live_nodes_kept "consumers: $(consumers | tr '\n' ' ')" [ "$(consumers | wc -l)" = 2 ]
wait_until 10 bash -c "[ \$(curl -s '${NODE_URL[3]}/metrics' | awk '\$1 == \"rayd_cluster_nodes\" {print \$2}') = 2 ]"
check live_nodes_metric "rayd_cluster_nodes $(metric 3 rayd_cluster_nodes)" [ "$(metric 3 rayd_cluster_nodes)" = 2 ]
# each node counts the live nodes on its own heartbeat: node 1 may see the change a beat later
wait_until 10 bash -c "curl -s '${NODE_URL[1]}/healthz' | grep -q '\"nodes\":2,'"
check live_nodes_healthz "$(curl -s "${NODE_URL[1]}/healthz")" bash -c "curl -s '${NODE_URL[1]}/healthz' | grep -q '\"nodes\":2,'"

for i in 1 3; do
    kill -0 "${NODE_PID[$i]}" 2>/dev/null || fail "node_${i}_alive" "node $i died: $(tail -n 3 "$T/node$i.err")"
done
pass nodes_alive

# --- a clean stop removes its own consumer (it holds nothing) at once -------------------------
LEFT="$(hostname):${NODE_URL[3]##*:}:${NODE_PID[3]}"
kill -TERM "${NODE_PID[3]}"
wait "${NODE_PID[3]}"
rc=$?
check clean_stop_exit "node 3 exited with $rc" [ "$rc" = 0 ]
check clean_stop_consumer_removed "consumers: $(consumers | tr '\n' ' ')" bash -c "! grep -qxF '$LEFT' <<<'$(consumers)'"
check clean_stop_heartbeat_removed "rayd:nodes: $(rcli hkeys rayd:nodes | tr '\n' ' ')" [ -z "$(rcli hget rayd:nodes "$LEFT")" ]

# --- nodes whose clocks are an hour off, either way: neither is taken for gone, times agree ----
# (liveness is judged by Redis's clock; with the nodes' own, node 1 would count node 4 gone and
# reap its heartbeat, and node 5 would count every other node gone)
for i in 4 5; do
    RAYD_TEST_CLUSTER_SKEW_S=$([ $i = 4 ] && echo -3600 || echo 3600) \
        start_node $i --threads 1 --redis-claim-ms 1000 --test-gate open --redis "$REDIS_URL"
done
three() { for i in 1 4 5; do [ "$(metric $i rayd_cluster_nodes)" = 3 ] || return 1; done; }
wait_until 20 three
check skewed_clocks_counted "rayd_cluster_nodes of nodes 1, 4, 5: $(metric 1 rayd_cluster_nodes) $(metric 4 rayd_cluster_nodes) $(metric 5 rayd_cluster_nodes)" three
sleep 4 # past the gone rule (3 x claim-ms): nothing may be reaped meanwhile
check skewed_clocks_still_counted "rayd_cluster_nodes of nodes 1, 4, 5: $(metric 1 rayd_cluster_nodes) $(metric 4 rayd_cluster_nodes) $(metric 5 rayd_cluster_nodes)" three
name() { echo "$(hostname):${NODE_URL[$1]##*:}:${NODE_PID[$1]}"; }
reaped() { cat "$T"/node*.err | grep -E "gone node's (consumer|heartbeat) ($(name 1)|$(name 4)|$(name 5)) removed"; }
none_reaped() { [ -z "$(reaped)" ]; }
check skewed_clocks_nothing_reaped "$(reaped | head -3)" none_reaped
# a job's times are Redis's too: posted on the node an hour behind, the three nodes show one
# created_at, and an age of seconds, not an hour (or a negative one)
SK=$(curl -s "${JSON[@]}" --data-binary @"$SCENE" "${NODE_URL[4]}/v1/jobs?x=0&y=0&w=64&h=64" |
    python3 -c 'import json,sys; print(json.load(sys.stdin)["id"])')
times() { for i in 1 4 5; do curl -s "${NODE_URL[$i]}/v1/jobs/$SK" | python3 -c 'import json,sys; d=json.load(sys.stdin); print(d["created_at"], 0 <= d["age_s"] < 60)'; done | sort -u; }
seen=$(times)
check skewed_clocks_same_job_times "created_at, age under a minute, on nodes 1, 4, 5: $(tr '\n' ' ' <<<"$seen")" \
    bash -c "[ \"\$(wc -l <<<'$seen')\" = 1 ] && grep -q ' True\$' <<<'$seen'"
[ "$NFAIL" = 0 ]
