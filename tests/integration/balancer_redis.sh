#!/usr/bin/env bash
# balancer_redis.sh -- docker/compose.yml's cluster on loopback: a Redis
# configured as the compose file's (AOF, noeviction), three
# `rayd --redis` nodes, and Debian's nginx running docker/nginx.conf itself
# (lib/nginx.sh).  Checks that the balancer needs no 404 retry any more:
# - a job posted through nginx is answered by whatever node nginx picks:
#   every poll 200 from the first node tried (no retry in the access log),
#   polls reaching more than one node, the image byte-identical to
#   rayd-render's, the events through nginx unbuffered, DELETE from any node;
# - Redis down: a job request through nginx is the nodes' 503
#   cluster_unavailable with Retry-After, after nginx tried every node (a
#   503 is retried, as a busy node's), and renders still go through.
# Skips (passes nothing) when this rayd has no --redis.  Every process is
# stopped by its PID; everything stays on loopback.
source "$(dirname "$0")/lib/common.sh"
source "$RAYD_ROOT/tests/integration/lib/nginx.sh"

if ! "$RAYD" --help 2>&1 | grep -q -- '--redis'; then
    echo "SKIP balancer_redis: this rayd has no --redis"
    exit 0
fi
NGINX=$(command -v nginx || echo /usr/sbin/nginx)
[ -x "$NGINX" ] || { echo "FAIL setup: nginx missing (make deps installs it)"; exit 1; }
REDIS_SERVER=$(command -v redis-server || echo /usr/bin/redis-server)
[ -x "$REDIS_SERVER" ] || { echo "FAIL setup: redis-server missing (make test-deps installs it)"; exit 1; }

# --- Redis as docker/compose.yml runs it, on a free port ---------------------------
redis_up() { redis-cli -h 127.0.0.1 -p "$REDIS_PORT" ping 2>/dev/null | grep -q PONG; }
redis_up_or_gone() { redis_up || ! kill -0 "$REDIS_PID" 2>/dev/null; }
mkdir -p "$T/redis"
for _ in 1 2 3 4 5; do
    REDIS_PORT=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
    "$REDIS_SERVER" --bind 127.0.0.1 --port "$REDIS_PORT" --dir "$T/redis" --save "" --appendonly yes \
        --appendfsync everysec --maxmemory-policy noeviction >>"$T/redis/log" 2>&1 &
    REDIS_PID=$!
    PIDS+=("$REDIS_PID")
    wait_until 20 redis_up_or_gone
    redis_up && break
done
redis_up || { echo "FAIL setup: redis-server did not start: $(tail -n 3 "$T/redis/log")"; exit 1; }

for i in 1 2 3; do
    start_node $i --threads 1 --redis "redis://127.0.0.1:$REDIS_PORT" --cluster-tile 32
done
NG=$T/nginx
nginx_start "$NG" "${NODE_URL[1]#http://}" "${NODE_URL[2]#http://}" "${NODE_URL[3]#http://}"
URL=http://127.0.0.1:$NGINX_PORT     # req, post_json: through nginx
wait_until 60 bash -c "[ \"\$(curl -s -o /dev/null -w '%{http_code}' '$URL/healthz')\" = 200 ]"

# --- a job through nginx: any node answers, none is retried --------------------------
scene "$T/j.json" 96 64 1 spheres 7
code=$(post_json /v1/jobs "$T/j.json")
id=$(jfield "$T/body" id)
check job_created "$code $(head -c 200 "$T/body")" bash -c "[ '$code' = 202 ] && [ -n '$id' ]"
state_is() { [ "$(req GET "/v1/jobs/$id")" = 200 ] && [ "$(jfield "$T/body" state)" = "$1" ]; }
wait_until 60 state_is succeeded
check job_succeeded "state '$(jfield "$T/body" state)'" state_is succeeded
polls_ok=1 why="" ups=""
for p in $(seq 1 9); do
    code=$(req GET "/v1/jobs/$id")
    up=$(header X-Upstream)
    [ "$code" = 200 ] && [ "$(jfield "$T/body" id)" = "$id" ] && [[ $up != *", "* ]] ||
        { polls_ok=0 why+=" poll $p: $code via '$up'"; }
    ups+="$up"$'\n'
done
check polls_any_node_no_retry "$why" [ $polls_ok = 1 ]
nups=$(printf '%s' "$ups" | sort -u | grep -c .)
check polls_spread "polls reached: $(printf '%s' "$ups" | sort -u | tr '\n' ' ')" [ "$nups" -ge 2 ]
retried=$(grep -F "/v1/jobs/$id" "$NG/log/access.log" | grep -c 'ustatus=[0-9]*, ')
check access_log_no_retry "$retried job requests tried more than one node" [ "$retried" = 0 ]

code=$(req GET "/v1/jobs/$id/image.png")
cp "$T/body" "$T/job.png"
"$RENDER" "$T/j.json" -o "$T/ref.png" 2>/dev/null
check image_byte_identical "$code, $(wc -c <"$T/job.png") bytes against rayd-render's $(wc -c <"$T/ref.png" 2>/dev/null)" \
    bash -c "[ '$code' = 200 ] && cmp -s '$T/job.png' '$T/ref.png'"
curl -s -N -m 5 -H 'Accept: text/event-stream' "$URL/v1/jobs/$id/events" >"$T/events" 2>/dev/null
check events_through_nginx "events: $(head -c 300 "$T/events")" grep -q succeeded "$T/events"
code=$(req DELETE "/v1/jobs/$id")
check delete_any_node "$code $(head -c 200 "$T/body")" [ "$code" = 200 ]
code=$(req GET /v1/jobs/00000000000000000000000000000000)
check unknown_404_once "$code via '$(header X-Upstream)'" \
    bash -c "[ '$code' = 404 ] && [[ '$(header X-Upstream)' != *', '* ]]"

# --- Redis down: 503 from every node, renders go on ------------------------------------
check redis_still_up "redis-server (PID $REDIS_PID) ended before the test stopped it: $(tail -n 20 "$T/redis/log" | tr '\n' '|')" \
    kill -0 "$REDIS_PID"
kill -KILL "$REDIS_PID"
wait "$REDIS_PID" 2>/dev/null
code=$(req GET "/v1/jobs/$id")
ra=$(header Retry-After) up=$(header X-Upstream)
down_ok() { [ "$code" = 503 ] && [ -n "$ra" ] && err_is "$T/body" 503 cluster_unavailable; }
check redis_down_503 "$code Retry-After='$ra' $(head -c 200 "$T/body")" down_ok
check redis_down_every_node_tried "X-Upstream '$up'" bash -c "[ \$(tr ',' '\n' <<<'$up' | grep -c .) = 3 ]"
scene "$T/r.json" 48 32 1 spheres 9
code=$(post_json /v1/render "$T/r.json")
check redis_down_renders "$code" bash -c "[ '$code' = 200 ] && head -c 8 '$T/body' | od -An -tx1 | grep -q '89 50 4e 47'"

nginx_stop_check_nodes 3
exit $((NFAIL > 0))
