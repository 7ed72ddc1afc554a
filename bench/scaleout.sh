#!/usr/bin/env bash
# bench/scaleout.sh BUILD -- the cost of rendering one frame as tiles over
# several rayd nodes, directly and behind nginx (docker/nginx.conf).
#
# A 1920x1080 frame (scenes/whitted.json, SPP samples, default 1) is rendered
#   - once by rayd-render on 2 threads (the baseline: no HTTP, no tiles);
#   - by rayd-client over 1, 2 and 3 local nodes (each --threads 2), with the
#     servers as a list ("direct") and through nginx ("nginx");
#   - by rayd-client over 1 node with tiles of 64, 128, 256 and one tile for
#     the whole frame, to separate the cost of tiling from the cost of HTTP.
# Every run uses a fresh scene id (trailing spaces change the bytes, not the
# picture) so no node's result cache or nginx's tile cache answers.  Each
# figure is the median of RUNS runs (default 3).
#
# All nodes share this machine's cores, so more nodes cannot go faster here:
# the table reports overhead (wall time over the baseline, minus 1) and
# efficiency (baseline / wall time), not speed-up.  docs/operations.md
# explains what the figures mean for a real cluster.
set -eu
cd "$(dirname "$0")/.."
BUILD=$(cd "${1:-build}" && pwd)
RUNS=${RUNS:-3}
SPP=${SPP:-1}
TILE=${TILE:-128}
NGINX=$(command -v nginx || echo /usr/sbin/nginx)
tmp=$(mktemp -d "${TMPDIR:-/tmp}/rayd-scaleout.XXXXXX")
pids=()
cleanup() {
    local p
    for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null; done
    wait 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT

seq_no=0
# mkscene OUT: the frame with a fresh id
mkscene() {
    seq_no=$((seq_no + 1))
    python3 - "$1" "$SPP" "$seq_no" <<'PY'
import json, sys
d = json.load(open("scenes/whitted.json"))
d.setdefault("render", {}).update(width=1920, height=1080, samples=int(sys.argv[2]))
open(sys.argv[1], "w").write(json.dumps(d) + " " * int(sys.argv[3]))
PY
}
now() { date +%s.%N; }
median() { sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }

urls=()
for i in 1 2 3; do
    "$BUILD/rayd" --bind 127.0.0.1 --port 0 --threads 2 >"$tmp/node$i.out" 2>/dev/null &
    pids+=($!)
    for _ in $(seq 1 200); do [ -s "$tmp/node$i.out" ] && break; sleep 0.05; done
    urls+=("$(sed -n 's/^rayd listening on //p' "$tmp/node$i.out")")
done

# nginx on loopback, one configuration per node count (same rewrite as the test)
ngstart() { # ngstart N: nginx over the first N nodes; sets LB
    local n=$1 d=$tmp/nginx$1 nodes="" i port
    mkdir -p "$d/cache" "$d/log"
    for ((i = 0; i < n; i++)); do nodes+="        server ${urls[$i]#http://} max_fails=1 fail_timeout=5s;\n"; done
    port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
    awk -v nodes="$nodes" -v port="$port" '
        /^ *server .*# @node/ { if (!innode) printf "%s", nodes; innode = 1; next }
                              { innode = 0 }
        /^ *listen .*# @listen/ { print "        listen 127.0.0.1:" port ";"; next }
                              { print }' docker/nginx.conf |
        sed -e "s#/var/cache/nginx#$d/cache#g" -e "s#/var/log/nginx#$d/log#g" \
            -e "s#/var/run/nginx.pid#$d/nginx.pid#g" >"$d/nginx.conf"
    local g="daemon off;"
    [ "$(id -u)" = 0 ] && g+=" user root;"
    "$NGINX" -p "$d" -c "$d/nginx.conf" -e "$d/log/error.log" -g "$g" 2>/dev/null &
    NGPID=$!
    pids+=($NGPID)
    LB=http://127.0.0.1:$port
    for _ in $(seq 1 100); do curl -s -o /dev/null "$LB/healthz" && break; sleep 0.05; done
}

# time_client ARGS...: median wall seconds of rayd-client render
time_client() {
    local t=() k t0 t1
    for k in $(seq "$RUNS"); do
        mkscene "$tmp/s.json"
        t0=$(now)
        "$BUILD/rayd-client" render "$tmp/s.json" -o "$tmp/out.png" --quiet "$@" ||
            { echo "rayd-client failed" >&2; exit 1; }
        t1=$(now)
        t+=("$(echo "$t1 - $t0" | bc -l)")
    done
    printf '%s\n' "${t[@]}" | median
}

tiles_of() { # tiles_of TILE
    echo $(( ((1920 + $1 - 1) / $1) * ((1080 + $1 - 1) / $1) ))
}

# baseline
b=()
for _ in $(seq "$RUNS"); do
    mkscene "$tmp/s.json"
    t0=$(now)
    "$BUILD/rayd-render" "$tmp/s.json" -o "$tmp/ref.png" --threads 2
    t1=$(now)
    b+=("$(echo "$t1 - $t0" | bc -l)")
done
base=$(printf '%s\n' "${b[@]}" | median)

row() { # row LABEL NODES TILE SECONDS
    local tiles; tiles=$(tiles_of "$3")
    awk -v l="$1" -v n="$2" -v tl="$3" -v tiles="$tiles" -v s="$4" -v b="$base" 'BEGIN {
        printf "%-8s %5s %6s %6d %8.3f %8.1f %+9.1f%% %8.0f%%\n", l, n, tl, tiles, s, tiles / s,
               (s / b - 1) * 100, b / s * 100 }'
}

echo "1920x1080 whitted, $SPP spp; rayd-render --threads 2: $(printf '%.3f' "$base") s (median of $RUNS); 2 cores shared by every node"
printf '%-8s %5s %6s %6s %8s %8s %10s %9s\n' mode nodes tile tiles "wall s" "tiles/s" overhead efficiency
for n in 1 2 3; do
    args=()
    for ((i = 0; i < n; i++)); do args+=(--server "${urls[$i]}"); done
    row direct "$n" "$TILE" "$(time_client "${args[@]}" --tile "$TILE")"
    ngstart "$n"
    row nginx "$n" "$TILE" "$(time_client --server "$LB" --tile "$TILE" --parallel $((4 * n)))"
    kill -QUIT "$NGPID" 2>/dev/null; wait "$NGPID" 2>/dev/null || true
done
echo "tile size, 1 node direct (tiling cost against one request for the whole frame):"
for tl in 64 128 256 1920; do
    row direct 1 "$tl" "$(time_client --server "${urls[0]}" --tile "$tl")"
done
