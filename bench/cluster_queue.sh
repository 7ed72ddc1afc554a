#!/usr/bin/env bash
# bench/cluster_queue.sh [BUILD] -- make bench-cluster: what the cluster's
# Redis costs per work item (issue 42), against which a tile's render time
# is set.  Starts its own redis-server on a free loopback port, configured
# as docker/compose.yml's (AOF on, fsync every second, no RDB, noeviction),
# in a temporary folder, and stops it by its PID; then runs
# build/bench/cluster_queue (bench/cluster_queue.c): enqueue (XADD), claim
# (XREADGROUP COUNT 1 by 1, 2, 4, 8 consumers), ack (XACK + XDEL), and a
# tile's PNG written and read as a Redis string and as a file on a volume
# (write, fsync, rename).  ITEMS (default 5000) items, RUNS (default 5)
# runs, medians; then redis-benchmark's SET/GET on the same server, for
# scale.  DIR (default a folder under BUILD) holds the files: put
# it on the disk (or the shared volume) the nodes would use, not on a
# tmpfs, for a real fsync.  Figures: bench/README.md, docs/operations.md.
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
ITEMS=${ITEMS:-5000}
RUNS=${RUNS:-5}
DIR=${DIR:-$BUILD/bench-cluster-files}
REDIS=$(command -v redis-server || echo /usr/bin/redis-server)
[ -x "$REDIS" ] || { echo "bench/cluster_queue.sh: no redis-server (make test-deps installs it)"; exit 1; }
T=$(mktemp -d "${TMPDIR:-/tmp}/rayd-cluster-bench.XXXXXX")
RPID=
cleanup() {
    [ -n "$RPID" ] && kill "$RPID" 2>/dev/null && wait "$RPID" 2>/dev/null
    rm -rf "$T" "$DIR"
}
trap cleanup EXIT
mkdir -p "$DIR"

# a free port: bound and released, then given to redis-server; should
# another program take it first, redis-server exits and another is tried
for _ in 1 2 3 4 5; do
    PORT=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
    "$REDIS" --bind 127.0.0.1 --port "$PORT" --dir "$T" --save "" --appendonly yes \
        --appendfsync everysec --maxmemory-policy noeviction --logfile "$T/redis.log" &
    RPID=$!
    for _ in $(seq 1 100); do
        redis-cli -p "$PORT" ping 2>/dev/null | grep -q PONG && break
        kill -0 "$RPID" 2>/dev/null || break
        sleep 0.05
    done
    redis-cli -p "$PORT" ping 2>/dev/null | grep -q PONG && break
    wait "$RPID" 2>/dev/null || true
    RPID=
done
[ -n "$RPID" ] || { echo "bench/cluster_queue.sh: redis-server did not start: $(tail -n 3 "$T/redis.log")"; exit 1; }

echo "-- $("$REDIS" --version | cut -d' ' -f1-3), AOF everysec, on 127.0.0.1; $(nproc) cores" \
     "(load $(cut -d' ' -f1-3 /proc/loadavg)); files in $DIR ($(df -PT "$DIR" | awk 'NR==2 {print $2}'))"
"$BUILD/bench/cluster_queue" 127.0.0.1 "$PORT" "$DIR" "$ITEMS" "$RUNS"

# Redis's own tool on the same server, for scale: simple SET/GET of 3 bytes
# by one connection, by 50, and by 50 with 16 commands in flight each
if command -v redis-benchmark >/dev/null 2>&1; then
    echo "-- redis-benchmark -t set,get -n 50000 on the same Redis (requests/s)"
    for opts in "-c 1" "-c 50" "-c 50 -P 16"; do
        # shellcheck disable=SC2086 # opts is a list of words
        redis-benchmark -p "$PORT" -q -n 50000 -t set,get $opts 2>/dev/null | tr '\r' '\n' |
            awk -v o="$opts" '/requests per second/ && !/rps=/ {sub(/:$/, "", $1); printf "%-12s %-4s %10.0f\n", o, $1, $2}'
    done
fi
