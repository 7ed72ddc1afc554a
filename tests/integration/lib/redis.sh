# tests/integration/lib/redis.sh -- a real redis-server for the cluster tests.
# Sourced after common.sh.  start_redis starts Debian's redis-server on a
# free loopback port (picked by the kernel, then given to Redis; tried again
# on a clash) with no RDB, an AOF written at every command (so a kill -9
# loses nothing) and its files in $T/redis; it sets REDIS_PID, REDIS_PORT
# and REDIS_URL.  restart_redis starts it again on the same port and folder
# (the same AOF).  rcli runs redis-cli against it; listed_jobs counts the
# jobs in the clients' lists.  Stopped by PID.
REDIS_SERVER=$(command -v redis-server || echo /usr/bin/redis-server)
REDIS_CLI=$(command -v redis-cli || echo /usr/bin/redis-cli)
REDIS_PID= REDIS_PORT= REDIS_URL=

free_port() {
    python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

rcli() { "$REDIS_CLI" -h 127.0.0.1 -p "$REDIS_PORT" ${REDIS_AUTH:+-a "$REDIS_AUTH" --no-auth-warning} "$@"; }
export -f rcli

# redis_on PORT [ARGS...]: starts redis-server on PORT; 0 once it answers PING.
redis_on() {
    local port=$1; shift
    mkdir -p "$T/redis"
    "$REDIS_SERVER" --bind 127.0.0.1 --port "$port" --save "" --appendonly yes \
        --appendfsync always --dir "$T/redis" "$@" >>"$T/redis/log" 2>&1 &
    REDIS_PID=$!
    PIDS+=("$REDIS_PID")
    REDIS_PORT=$port
    export REDIS_CLI REDIS_PORT
    wait_until 20 bash -c "'$REDIS_CLI' -h 127.0.0.1 -p $port ${REDIS_AUTH:+-a $REDIS_AUTH --no-auth-warning} ping 2>/dev/null | grep -q PONG"
}

start_redis() {
    [ -x "$REDIS_SERVER" ] || { echo "FAIL setup: redis-server missing (make test-deps installs it)"; exit 1; }
    local i
    for i in 1 2 3 4 5; do
        redis_on "$(free_port)" "$@" && break
        kill -KILL "$REDIS_PID" 2>/dev/null
        REDIS_PID=
    done
    [ -n "$REDIS_PID" ] || { echo "FAIL setup: redis-server did not start"; cat "$T/redis/log"; exit 1; }
    REDIS_URL=redis://127.0.0.1:$REDIS_PORT
}

restart_redis() { redis_on "$REDIS_PORT" "$@"; }

stop_redis() { # kill -9, by PID
    kill -KILL "$REDIS_PID" 2>/dev/null
    wait "$REDIS_PID" 2>/dev/null
}

# listed_jobs: the jobs in every client's list (the ZSETs rayd:jobs:CLIENT)
listed_jobs() {
    local k n=0
    for k in $(rcli --scan --pattern 'rayd:jobs:*'); do n=$((n + $(rcli zcard "$k"))); done
    echo "$n"
}

# metric I NAME: node I's value of NAME on /metrics (0 if absent)
metric() {
    local v
    v=$(curl -s -m 30 "${NODE_URL[$1]}/metrics" | awk -v k="$2" '$1 == k {print $2}')
    echo "${v:-0}"
}

# job_state URL ID: the job's state ("" when there is none)
job_state() {
    curl -s -m 30 "$1/v1/jobs/$2" | python3 -c 'import json, sys
try: print(json.load(sys.stdin).get("state", ""))
except Exception: print("")'
}
