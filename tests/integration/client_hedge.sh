#!/usr/bin/env bash
# client_hedge.sh -- rayd-client hedges the tiles of a stalled node.
#
# Two nodes, both started with the test gate shut (--test-gate 0): once B
# has learnt the scene, A's gate opens and B's lets one tile through, and B
# is stopped with SIGSTOP once it holds a tile at its gate.  A draws every other tile; B's tiles are
# left in flight, and once none is left to start the client must send a copy
# of each to A and use A's answer, long before the per-request --timeout
# (600 s, longer than the 300 s the whole render may take here, so the
# frame can only be finished by hedging).  The frame is rayd-render's byte for byte, the end
# line counts the hedged tiles and those that won, --quiet prints nothing,
# --no-hedge leaves the count out, and healthy nodes hedge at most the
# tiles in flight at the end.  A node that learns the scene late (stopped
# until the other holds its share of the slots) still gets tiles.  The order of events is held by the gates, not
# by timing, and no time is judged.  Every node is
# resumed (SIGCONT) and stopped by its PID.
source "$(dirname "$0")/lib/common.sh"

CLIENT=$RAYD_BUILD/rayd-client
[ -x "$CLIENT" ] || { echo "FAIL setup: $CLIENT missing"; exit 1; }

# node_gate I TILES: lets TILES more tiles start on node I ("open": all)
node_gate() { curl -s -m 30 -X POST -o /dev/null "${NODE_URL[$1]}/v1/test/gate?tiles=$2"; }
# node_holds I: node I has a tile waiting at its gate
node_holds() {
    local held
    held=$(curl -s -m 5 "${NODE_URL[$1]}/v1/test/gate" | jfield /dev/stdin held)
    [ "${held:-0}" -ge 1 ]
}
# node_learnt I: node I has answered the client's POST /v1/scenes
node_learnt() {
    curl -s -m 5 "${NODE_URL[$1]}/metrics" |
        grep -q '^rayd_http_requests_total{route="/v1/scenes",method="POST",code="201"} [1-9]'
}
stop_nodes() {
    local p
    for p in "${NODE_PID[@]}"; do
        kill -CONT "$p" 2>/dev/null
        kill -TERM "$p" 2>/dev/null
    done
    for p in "${NODE_PID[@]}"; do wait "$p" 2>/dev/null; done
    NODE_PID=()
}
# hedges FILE: "HEDGED WON" from the client's end line, empty if absent
hedges() { sed -n 's/.*tiles hedged: \([0-9]*\), won: \([0-9]*\)$/\1 \2/p' "$1"; }

scene "$T/s.json" 160 96 1 spheres
"$RENDER" "$T/s.json" -o "$T/ref.png" 2>/dev/null

# stalled NAME [ARGS...]: one frame over A and B, B stopped while it holds a
# tile; sets RC and SECS, stderr in $T/NAME.err
stalled() {
    local name=$1 t0 cpid; shift
    start_node 1 --threads 1 --test-gate 0
    start_node 2 --threads 1 --test-gate 0
    t0=$(date +%s%N)
    timeout 300 "$CLIENT" render "$T/s.json" -o "$T/$name.png" --tile 16 --timeout 600 \
        --server "${NODE_URL[1]}" --server "${NODE_URL[2]}" "$@" 2>"$T/$name.err" &
    cpid=$!
    # B has the scene before anything is drawn.  Whichever node learnt it
    # first holds its share of the slots (--parallel over the two); B draws
    # one tile, and from then on B takes tiles as slots free and holds them
    # at its gate until it is stopped
    if wait_until 60 node_learnt 2 && node_gate 1 open && node_gate 2 1 &&
        wait_until 60 node_holds 2; then
        kill -STOP "${NODE_PID[2]}"
    else
        fail "${name}_setup" "the nodes never held a tile: $(head -c 300 "$T/$name.err")"
        node_gate 1 open
        node_gate 2 open
    fi
    wait "$cpid"
    RC=$?
    SECS=$((($(date +%s%N) - t0) / 1000000000))
    stop_nodes
}

stalled hedge
read -r HEDGED WON <<<"$(hedges "$T/hedge.err")"
check hedge_exit "exit $RC: $(tail -n 3 "$T/hedge.err")" [ "$RC" = 0 ]
check hedge_frame "the frame differs from rayd-render's" cmp -s "$T/ref.png" "$T/hedge.png"
check hedge_counted "end line: $(tail -n 1 "$T/hedge.err")" \
    bash -c "[ '${WON:-0}' -ge 1 ] && [ '${HEDGED:-0}' -ge '${WON:-0}' ]"
# B's tiles never come back (per-request --timeout 600 s, and timeout(1)
# ends the client at 300 s): the frame is done only if A drew them
check hedge_before_timeout "exit $RC after $SECS s" bash -c "[ $RC = 0 ] && [ $SECS -lt 300 ]"

stalled hedge_quiet --quiet
check hedge_quiet "exit $RC, stderr: $(head -c 300 "$T/hedge_quiet.err")" \
    bash -c "[ $RC = 0 ] && [ ! -s '$T/hedge_quiet.err' ] && cmp -s '$T/ref.png' '$T/hedge_quiet.png'"

# A node that learns the scene late still finds slots: A holds every tile
# it gets at its shut gate while B, stopped, cannot answer its POST
# /v1/scenes.  A must take only its share of the 8 slots (4), so B, resumed,
# draws the tiles left and then copies of A's 4 held ones: the frame is
# done with A's gate still shut.  Were A given every slot, B would get none
# until the per-request --timeout (600 s, past timeout(1)'s 120).
# node_waiting I: node I's tiles held at its gate or queued behind it
node_waiting() {
    local g
    g=$(curl -s -m 5 "${NODE_URL[$1]}/v1/test/gate")
    echo $(($(jfield /dev/stdin held <<<"$g") + $(jfield /dev/stdin queued <<<"$g")))
}
node_waiting_4() { [ "$(node_waiting "$1")" -ge 4 ] 2>/dev/null; }
start_node 1 --threads 1 --test-gate 0
start_node 2 --threads 1 --test-gate open
kill -STOP "${NODE_PID[2]}"
timeout 120 "$CLIENT" render "$T/s.json" -o "$T/late.png" --tile 16 --timeout 600 \
    --server "${NODE_URL[1]}" --server "${NODE_URL[2]}" 2>"$T/late.err" &
cpid=$!
wait_until 60 node_waiting_4 1
sleep 0.5 # (more would come at once: the client sends a slot's tile as it frees)
held=$(node_waiting 1)
kill -CONT "${NODE_PID[2]}"
wait "$cpid"
RC=$?
node_gate 1 open
check late_learner_drawn "exit $RC: $(tail -n 3 "$T/late.err")" \
    bash -c "[ $RC = 0 ] && cmp -s '$T/ref.png' '$T/late.png'"
# (4 requests; the one at the gate counts twice while its request has
# tiles nobody started: held and queued)
check late_learner_share "A had '$held' tiles waiting, not its share of 4" \
    bash -c "[ '$held' -ge 4 ] && [ '$held' -le 5 ]"

stop_nodes

# healthy nodes: the same frame; hedges only at the end, so never more than
# the requests in flight then (--parallel)
start_node 1 --threads 1 --test-gate open
start_node 2 --threads 1 --test-gate open
timeout 120 "$CLIENT" render "$T/s.json" -o "$T/ok.png" --tile 16 --parallel 4 \
    --server "${NODE_URL[1]}" --server "${NODE_URL[2]}" 2>"$T/ok.err"
RC=$?
read -r HEDGED WON <<<"$(hedges "$T/ok.err")"
check healthy_frame "exit $RC: $(tail -n 3 "$T/ok.err")" \
    bash -c "[ $RC = 0 ] && cmp -s '$T/ref.png' '$T/ok.png'"
check healthy_hedges_bounded "end line: $(tail -n 1 "$T/ok.err")" \
    bash -c "[ -n '$HEDGED' ] && [ '${HEDGED:-0}' -le 4 ]"

timeout 120 "$CLIENT" render "$T/s.json" -o "$T/off.png" --tile 16 --no-hedge \
    --server "${NODE_URL[1]}" --server "${NODE_URL[2]}" 2>"$T/off.err"
RC=$?
check no_hedge "exit $RC: $(tail -n 2 "$T/off.err")" \
    bash -c "[ $RC = 0 ] && cmp -s '$T/ref.png' '$T/off.png' && grep -q 'scene sent' '$T/off.err' && ! grep -q hedged '$T/off.err'"
stop_nodes

[ "$NFAIL" = 0 ]
