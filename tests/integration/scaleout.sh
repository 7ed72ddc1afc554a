#!/usr/bin/env bash
# scaleout.sh -- one frame over three rayd nodes, directly and behind nginx.
#
# Starts three `rayd --port 0` on 127.0.0.1 and Debian's nginx on a free
# loopback port with docker/nginx.conf itself (its "# @node" and "# @listen"
# lines and its paths rewritten for a temporary folder by lib/nginx.sh;
# tests/integration/balancer.sh checks busy nodes, jobs and the cache key
# through it), then checks that
# rayd-client's stitched frames equal rayd-render's pixels through nginx and
# with the servers as a list, that tiles spread over every node (from each
# node's /metrics), that a node learns a scene once, that nginx caches the
# immutable tiles, that a node killed with SIGKILL mid-frame costs nothing
# but time, and that with every node down the client fails loudly without
# writing an image.  Also: job through nginx, health, a refused scene's JSON
# error, mesh and environment files inlined, programs/curl/rayd-curl.sh.  Every process is stopped
# by its PID; everything stays on loopback.
# rayd-test: long (three nodes and nginx, several kills)
source "$(dirname "$0")/lib/common.sh"

CLIENT=$RAYD_BUILD/rayd-client
PNGCMP=$RAYD_BUILD/tests/tools/pngcmp
NGINX=$(command -v nginx || echo /usr/sbin/nginx)
[ -x "$CLIENT" ] || { echo "FAIL setup: $CLIENT missing"; exit 1; }
[ -x "$PNGCMP" ] || { echo "FAIL setup: $PNGCMP missing (make test builds it)"; exit 1; }
[ -x "$NGINX" ] || { echo "FAIL setup: nginx missing (make test-deps installs it)"; exit 1; }

# --- three nodes ---------------------------------------------------------------
# --test-gate open: the kill cases below hold a node's tiles with it.  They
# share a Redis (--redis), as docker/compose.yml's nodes do: docker/nginx.conf
# sends a job's polls to any node
source "$(dirname "$0")/lib/redis.sh"
start_redis
for i in 1 2 3; do start_node $i --threads 2 --test-gate open --redis "$REDIS_URL"; done

# node_count I "METHOD ROUTE" CODE: rayd_http_requests_total of node I (0 if absent)
node_count() {
    local v method=${2%% *} route=${2#* }
    v=$(curl -s -m 60 "${NODE_URL[$1]}/metrics" |
        awk -v k="rayd_http_requests_total{route=\"$route\",method=\"$method\",code=\"$3\"} " 'index($0, k) == 1 {print $NF}')
    echo "${v:-0}"
}
node_tiles() { # tiles answered by node I: GET image 200 + POST render 200
    echo $(($(node_count "$1" "GET /v1/scenes/{id}/image.png" 200) + $(node_count "$1" "POST /v1/render" 200)))
}

# --- nginx with docker/nginx.conf ------------------------------------------------
NG=$T/nginx
source "$RAYD_ROOT/tests/integration/lib/nginx.sh"
nginx_start "$NG" "${NODE_URL[1]#http://}" "${NODE_URL[2]#http://}" "${NODE_URL[3]#http://}"
LB=http://127.0.0.1:$NGINX_PORT
wait_until 60 bash -c "[ \"\$(curl -s -o /dev/null -w '%{http_code}' '$LB/healthz')\" = 200 ]"
check nginx_up "nginx does not answer /healthz on $LB" [ "$(curl -s -o /dev/null -w '%{http_code}' "$LB/healthz")" = 200 ]

# client NAME ARGS...: runs rayd-client, stderr in $T/NAME.err, sets RC; a
# sanitizer report (SANITIZE=1 builds) fails the case
client() {
    local name=$1; shift
    timeout 200 "$CLIENT" "$@" 2>"$T/$name.err" >"$T/$name.out"
    RC=$?
    if grep -Eq 'ERROR: (Address|Leak)Sanitizer|runtime error:' "$T/$name.err"; then
        fail "${name}_sanitizer" "$(grep -Em 3 'Sanitizer|runtime error' "$T/$name.err")"
    fi
}
same() { "$PNGCMP" "$1" "$2" 2>>"$T/pngcmp.err"; }

# --- through nginx: identical pixels, spread, learned, cached ---------------------
scene "$T/a.json" 400 300 2 whitted 1
"$RENDER" "$T/a.json" -o "$T/a_ref.png" 2>/dev/null
declare -A before
for i in 1 2 3; do before[$i]=$(node_tiles $i); done
client nginx_render render "$T/a.json" -o "$T/a.png" --server "$LB" --tile 64 --parallel 6
check nginx_render_exit "exit $RC: $(tail -n 3 "$T/nginx_render.err")" [ "$RC" = 0 ]
check nginx_render_identical "differs from rayd-render" same "$T/a_ref.png" "$T/a.png"
spread=1 per=""
for i in 1 2 3; do
    n=$(($(node_tiles $i) - before[$i])); per+=" node$i=$n"
    [ "$n" -gt 0 ] || spread=0
done
check nginx_tiles_spread "tiles per node:$per" [ $spread = 1 ]
sent=$(sed -n 's/.*scene sent \([0-9]*\) time.*/\1/p' "$T/nginx_render.err")
# one POST /v1/scenes, plus a POST /v1/render for each tile that raced to a
# node before it knew the scene (about --parallel 6 at the start; typically
# 4-6), far from one per tile (35)
check nginx_scene_uploads_bounded "scene sent '$sent' times" [ "${sent:-99}" -le 12 ]
echo "# through nginx the scene was sent $sent times for 35 tiles"
check nginx_progress_lines "no plain progress lines on a non-tty stderr" \
    grep -q '^rayd-client: 35/35 tiles (100%)' "$T/nginx_render.err"

# the same frame again: every tile is an immutable GET served by nginx's cache
for i in 1 2 3; do before[$i]=$(node_tiles $i); done
hits0=$(grep -c 'cache=HIT' "$NG/log/access.log")
client nginx_cached render "$T/a.json" -o "$T/a2.png" --server "$LB" --tile 64 --parallel 6
hits=$(($(grep -c 'cache=HIT' "$NG/log/access.log") - hits0))
node_work=0
for i in 1 2 3; do node_work=$((node_work + $(node_tiles $i) - before[$i])); done
# (tiles the first run got through POST /v1/render were not cached: 404 first)
check nginx_cache_hits "exit $RC, $hits cache hits, $node_work tiles rendered by nodes" \
    [ "$RC" = 0 -a "$hits" -ge 20 -a $((hits + node_work)) = 35 ]
check nginx_cached_identical "differs" same "$T/a_ref.png" "$T/a2.png"

# --- the servers as a list, no nginx -------------------------------------------
scene "$T/b.json" 400 300 2 whitted 2
"$RENDER" "$T/b.json" -o "$T/b_ref.png" 2>/dev/null
for i in 1 2 3; do before[$i]=$(node_tiles $i); done
declare -A learn0 post0
for i in 1 2 3; do
    learn0[$i]=$(node_count $i "POST /v1/scenes" 201)
    post0[$i]=$(node_count $i "POST /v1/render" 200)
done
# Each node's test gate lets 4 tiles through and holds the rest, so the
# frame spreads over all three however fast each is: a held tile is a
# request in flight there, and the client sends the next tile to the node
# with the fewest.  Once every gate is spent the gates open for the rest.
# (A node holds at most its share of the client's 12 slots, 4, so a node
# that learns the scene last still finds slots free.)
gate() { curl -s -m 30 -o /dev/null -X POST "${NODE_URL[$1]}/v1/test/gate?tiles=$2"; }
gate_left() { curl -s -m 60 "${NODE_URL[$1]}/v1/test/gate" | sed -n 's/.*"tiles":\([0-9a-z"]*\).*/\1/p'; }
gates_spent() { for i in 1 2 3; do [ "$(gate_left $i)" = 0 ] || return 1; done; }
for i in 1 2 3; do gate $i 4; done
timeout 200 "$CLIENT" render "$T/b.json" -o "$T/b.png" --tile 64 \
    --server "${NODE_URL[1]}" --server "${NODE_URL[2]}/" --server "${NODE_URL[3]}" \
    2>"$T/list_render.err" >"$T/list_render.out" &
cpid=$!
wait_until 120 gates_spent
left=""
for i in 1 2 3; do left+=" node$i=$(gate_left $i)"; done
check list_gates_spent "tiles the gates still let through:$left" gates_spent
for i in 1 2 3; do gate $i open; done
wait $cpid
RC=$?
if grep -Eq 'ERROR: (Address|Leak)Sanitizer|runtime error:' "$T/list_render.err"; then
    fail list_render_sanitizer "$(grep -Em 3 'Sanitizer|runtime error' "$T/list_render.err")"
fi
check list_render_exit "exit $RC: $(tail -n 3 "$T/list_render.err")" [ "$RC" = 0 ]
check list_render_identical "differs from rayd-render" same "$T/b_ref.png" "$T/b.png"
spread=1 once=1 per="" learned=""
for i in 1 2 3; do
    n=$(($(node_tiles $i) - before[$i])); per+=" node$i=$n"
    # the gate counts the node's own tiles, and one 64x64 client tile may be
    # several of them: 4 let through is at least one client tile answered
    [ "$n" -ge 1 ] || spread=0
    l=$(($(node_count $i "POST /v1/scenes" 201) - learn0[$i]))
    p=$(($(node_count $i "POST /v1/render" 200) - post0[$i]))
    learned+=" node$i: scenes=$l render=$p"
    [ "$l" = 1 -a "$p" = 0 ] || once=0
done
check list_tiles_spread "tiles per node:$per" [ $spread = 1 ]
check list_scene_learned_once "$learned" [ $once = 1 ]

# --- a scene a node refuses: the server's JSON error --------------------------------
scene "$T/huge.json" 5000 4000 1 spheres
client refused render "$T/huge.json" -o "$T/huge.png" --server "$LB"
check refused_exit_1 "exit $RC" [ "$RC" = 1 ]
check refused_json_error "stderr: $(head -c 300 "$T/refused.err")" \
    grep -q 'HTTP 413 too_large at /render: ' "$T/refused.err"
check refused_no_file "an image was written" [ ! -e "$T/huge.png" ]

# --- job through nginx (any node answers: Redis), health, mesh files, rayd-curl.sh --
scene "$T/j.json" 200 150 2 instances 3
"$RENDER" "$T/j.json" -o "$T/j_ref.png" 2>/dev/null
client job job "$T/j.json" -o "$T/j.png" --server "$LB"
check job_through_nginx "exit $RC: $(tail -n 2 "$T/job.err")" bash -c "[ $RC = 0 ] && cmp -s '$T/j.png' '$T/j_ref.png'"
check job_progress_events "no progress from the event stream" grep -q 'tiles (100%)' "$T/job.err"

client health health --server "${NODE_URL[1]}" --server "${NODE_URL[2]}" --server "$LB"
check health_ok "exit $RC: $(cat "$T/health.out")" bash -c "[ $RC = 0 ] && [ \$(grep -c ': live (rayd [0-9.]*), ready' '$T/health.out') = 3 ]"

mkdir -p "$T/models"
printf 'v -1 0 0\nv 1 0 0\nv 0 1.5 0\nv 0 0.5 1\nf 1 2 3\nf 1 2 4\nf 2 3 4\nf 3 1 4\n' >"$T/models/tet.obj"
python3 - "$RAYD_ROOT/tests/scenes/spheres.json" "$T/mesh.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["render"]["width"], s["render"]["height"] = 160, 120
s["objects"].append({"type": "mesh", "source": {"file": "models/tet.obj"}, "material": {"color": [0.9, 0.6, 0.1]}})
json.dump(s, open(sys.argv[2], "w"))
PY
"$RENDER" "$T/mesh.json" -o "$T/mesh_ref.png" 2>/dev/null
client mesh render "$T/mesh.json" -o "$T/mesh.png" --server "${NODE_URL[1]}" --server "${NODE_URL[2]}" --tile 32
check mesh_file_inlined "exit $RC: $(tail -n 2 "$T/mesh.err")" bash -c "[ $RC = 0 ] && '$PNGCMP' '$T/mesh_ref.png' '$T/mesh.png'"
# an environment map's "file" is inlined too (as "base64")
cp "$RAYD_ROOT/scenes/sky.hdr" "$T/models/sky.hdr"
python3 - "$RAYD_ROOT/tests/scenes/spheres.json" "$T/env.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["render"]["width"], s["render"]["height"] = 96, 64
s["render"]["environment"] = {"file": "models/sky.hdr", "intensity": 0.5, "rotation": 20}
json.dump(s, open(sys.argv[2], "w"))
PY
"$RENDER" "$T/env.json" -o "$T/env_ref.png" 2>/dev/null
client env render "$T/env.json" -o "$T/env.png" --server "${NODE_URL[1]}" --server "${NODE_URL[2]}" --tile 32
check environment_file_inlined "exit $RC: $(tail -n 2 "$T/env.err")" bash -c "[ $RC = 0 ] && '$PNGCMP' '$T/env_ref.png' '$T/env.png'"

sh "$RAYD_ROOT/programs/curl/rayd-curl.sh" "$T/j.json" "$T/curl.png" "$LB" 2>"$T/curl.err"
check rayd_curl_through_nginx "exit $?: $(head -c 200 "$T/curl.err")" cmp -s "$T/curl.png" "$T/j_ref.png"
sh "$RAYD_ROOT/programs/curl/rayd-curl.sh" "$T/huge.json" "$T/curl2.png" "$LB" 2>"$T/curl2.err"
check rayd_curl_error "exit $? or no JSON error: $(head -c 200 "$T/curl2.err")" \
    bash -c "grep -q too_large '$T/curl2.err' && [ ! -e '$T/curl2.png' ]"

# --- a node with a token ------------------------------------------------------------
printf 'tok-%s\n' "$RANDOM$RANDOM" >"$T/token"
start_node 5 --threads 1 --token-file "$T/token"
TOK_PID=${NODE_PID[5]} TOK_URL=${NODE_URL[5]}
client token render "$T/j.json" -o "$T/tok.png" --server "$TOK_URL" --token-file "$T/token"
check token_render "exit $RC: $(tail -n 2 "$T/token.err")" bash -c "[ $RC = 0 ] && cmp -s '$T/tok.png' '$T/j_ref.png'"
client notoken render "$T/j.json" -o "$T/notok.png" --server "$TOK_URL"
check token_missing_refused "exit $RC: $(tail -n 1 "$T/notoken.err")" \
    bash -c "[ $RC = 1 ] && grep -q 'HTTP 401 unauthorized' '$T/notoken.err' && [ ! -e '$T/notok.png' ]"
RAYD_TOKEN_FILE=$T/token sh "$RAYD_ROOT/programs/curl/rayd-curl.sh" "$T/j.json" "$T/curl3.png" "$TOK_URL" 2>"$T/curl3.err"
check rayd_curl_token "exit $?: $(head -c 200 "$T/curl3.err")" cmp -s "$T/curl3.png" "$T/j_ref.png"
kill -TERM "$TOK_PID"
wait "$TOK_PID" 2>/dev/null
if grep -Eq 'ERROR: (Address|Leak)Sanitizer|runtime error:' "$T/node5.err"; then
    fail token_node_sanitizer "$(grep -Em 3 'Sanitizer|runtime error' "$T/node5.err")"
fi

# --- one frame's samples over the nodes (--split-samples) ---------------------------
# Each node renders a range of the samples and answers its exact sums; the
# client adds them up: the same PNG and EXR bytes as rayd-render.
scene "$T/s.json" 160 120 12 cornell 1
"$RENDER" "$T/s.json" -o "$T/s_ref.png" 2>/dev/null
"$RENDER" "$T/s.json" -o "$T/s_ref.exr" 2>/dev/null
client samples_nginx render "$T/s.json" -o "$T/s_lb.png" --split-samples 5 --server "$LB"
check samples_nginx_identical "exit $RC: $(tail -n 2 "$T/samples_nginx.err")" \
    bash -c "[ $RC = 0 ] && cmp -s '$T/s_lb.png' '$T/s_ref.png'"
client samples_nginx_exr render "$T/s.json" -o "$T/s_lb.exr" --split-samples 4 --server "$LB"
check samples_nginx_exr_identical "exit $RC: $(tail -n 2 "$T/samples_nginx_exr.err")" \
    bash -c "[ $RC = 0 ] && cmp -s '$T/s_lb.exr' '$T/s_ref.exr'"
before=()
for i in 1 2 3; do before[$i]=$(node_count $i "POST /v1/render" 200); done
client samples_list render "$T/s.json" -o "$T/s_list.png" --split-samples 6 \
    --server "${NODE_URL[1]}" --server "${NODE_URL[2]}" --server "${NODE_URL[3]}"
check samples_list_identical "exit $RC: $(tail -n 2 "$T/samples_list.err")" \
    bash -c "[ $RC = 0 ] && cmp -s '$T/s_list.png' '$T/s_ref.png'"
spread=1
for i in 1 2 3; do [ "$(node_count $i "POST /v1/render" 200)" -gt "${before[$i]}" ] || spread=0; done
check samples_list_spread "a node rendered no range" [ $spread = 1 ]
client samples_list_exr render "$T/s.json" -o "$T/s_list.exr" --split-samples 12 \
    --server "${NODE_URL[1]}" --server "${NODE_URL[2]}" --server "${NODE_URL[3]}"
check samples_list_exr_identical "exit $RC" bash -c "[ $RC = 0 ] && cmp -s '$T/s_list.exr' '$T/s_ref.exr'"
client samples_bad render "$T/s.json" -o "$T/s_bad.png" --split-samples 0 --server "$LB"
check samples_bad_option "exit $RC: $(head -c 200 "$T/samples_bad.err")" [ "$RC" = 2 ]

# --- SIGKILL of a node mid-frame -----------------------------------------------------
# kill_mid_frame NAME NODE SCENE SERVERS...: renders in the background, kills
# NODE once it has answered a few tiles, and expects the identical frame.
# NODE's test gate lets 3 tiles through and holds the rest, so the frame
# cannot be finished when the kill comes, however fast the machine
# (--no-hedge: else, once every other tile is drawn, copies of the held
# ones could finish the frame before a slow test sends the kill).
kill_mid_frame() {
    local name=$1 node=$2 sc=$3; shift 3
    "$RENDER" "$sc" -o "$T/$name.ref.png" 2>/dev/null
    local base; base=$(node_tiles "$node")
    # 40 tiles of the node's own: a client tile of these whitted scenes is
    # four (a costly scene's tiles are 32 pixels, cost.c), and tiles of
    # several client tiles interleave; enough for 3 answers, far from all
    curl -s -m 30 -o /dev/null -X POST "${NODE_URL[$node]}/v1/test/gate?tiles=40"
    timeout 200 "$CLIENT" render "$sc" -o "$T/$name.png" --tile 48 --no-hedge "$@" 2>"$T/$name.err" &
    local cpid=$!
    node_answered() { [ $(($(node_tiles "$node") - base)) -ge 3 ] || ! kill -0 $cpid 2>/dev/null; }
    wait_until 120 node_answered
    local alive=no
    kill -0 $cpid 2>/dev/null && alive=yes
    kill -KILL "${NODE_PID[$node]}"
    wait "${NODE_PID[$node]}" 2>/dev/null
    wait $cpid
    RC=$?
    check "${name}_killed_mid_frame" "the client had finished before the kill" [ $alive = yes ]
    check "${name}_completes" "exit $RC: $(tail -n 3 "$T/$name.err")" [ "$RC" = 0 ]
    check "${name}_identical" "differs from rayd-render" same "$T/$name.ref.png" "$T/$name.png"
}
scene "$T/k1.json" 480 360 8 whitted 4
kill_mid_frame kill_list 3 "$T/k1.json" --server "${NODE_URL[1]}" --server "${NODE_URL[2]}" --server "${NODE_URL[3]}"

# A node killed while it renders a sample range: the range is rendered
# again elsewhere and the frame is still the one render's.  A fourth node
# (node 3 is gone) lets 2 tiles of its range through and holds the rest;
# --no-hedge, so only the kill can move the held range (a hedged copy a
# second later could finish the frame before a slow test saw the gate).
start_node 4 --threads 2 --test-gate open
curl -s -m 30 -o /dev/null -X POST "${NODE_URL[4]}/v1/test/gate?tiles=2"
scene "$T/sk.json" 160 120 12 cornell 2
"$RENDER" "$T/sk.json" -o "$T/sk_ref.png" 2>/dev/null
timeout 200 "$CLIENT" render "$T/sk.json" -o "$T/sk.png" --split-samples 6 --no-hedge \
    --server "${NODE_URL[1]}" --server "${NODE_URL[2]}" --server "${NODE_URL[4]}" 2>"$T/sk.err" &
cpid=$!
node4_held() { [ "$(curl -s -m 5 "${NODE_URL[4]}/v1/test/gate" | sed -n 's/.*"started":\([0-9]*\).*/\1/p')" = 2 ]; }
wait_until 120 node4_held
alive=no
kill -0 $cpid 2>/dev/null && alive=yes
kill -KILL "${NODE_PID[4]}"
wait "${NODE_PID[4]}" 2>/dev/null
wait $cpid
RC=$?
check samples_kill_mid_frame "the client had finished before the kill" [ $alive = yes ]
check samples_kill_completes "exit $RC: $(tail -n 3 "$T/sk.err")" [ "$RC" = 0 ]
check samples_kill_identical "differs from rayd-render" cmp -s "$T/sk_ref.png" "$T/sk.png"

scene "$T/k2.json" 480 360 8 whitted 5
kill_mid_frame kill_nginx 2 "$T/k2.json" --server "$LB" --parallel 6

# --- every node down ----------------------------------------------------------------
kill -KILL "${NODE_PID[1]}"
wait "${NODE_PID[1]}" 2>/dev/null
scene "$T/d.json" 200 150 1 spheres 6
# --timeout 600, past client()'s timeout(1) at 200 s: a client that waited
# on the dead nodes instead of failing at once would end with 124, not 1
client down_list render "$T/d.json" -o "$T/d.png" --timeout 600 \
    --server "${NODE_URL[1]}" --server "${NODE_URL[2]}" --server "${NODE_URL[3]}"
check down_list_exit "exit $RC" [ "$RC" = 1 ]
check down_list_message "stderr: $(tail -n 2 "$T/down_list.err" | head -c 300)" \
    bash -c "grep -q 'incomplete image, nothing written to .*: 4 of 4 tiles missing; last error: .*onnect.*; missing: x=0 y=0 w=128 h=128' '$T/down_list.err'"
check down_list_no_file "an image was written" [ ! -e "$T/d.png" -a ! -e "$T/d.png.part" ]
client down_nginx render "$T/d.json" -o "$T/d.png" --server "$LB"
check down_nginx_exit "exit $RC: $(tail -n 2 "$T/down_nginx.err" | head -c 300)" \
    bash -c "[ $RC = 1 ] && grep -q 'tiles missing' '$T/down_nginx.err' && [ ! -e '$T/d.png' ]"

# --- stop nginx; sanitizer reports of the nodes (SANITIZE=1) ----------------------------
nginx_stop_check_nodes 3
