#!/usr/bin/env bash
# bench/scaleout.sh BUILD -- the cost of rendering one frame as tiles over
# several rayd nodes, directly and behind nginx (docker/nginx.conf).
#
# A 1920x1080 frame (scenes/whitted.json, SPP samples, default 1) is rendered
#   - by rayd-render on 2 threads (the baseline: no HTTP, no tiles), once
#     before every client run (paired, see below);
#   - by rayd-client over 1, 2 and 3 local nodes (each --threads
#     NODE_THREADS, default 2), with the servers as a list ("direct") and
#     through nginx ("nginx"), tiles of TILE pixels (default 128);
#   - by rayd-client over 1 node with tiles of 32, 64, 128, 256 and one tile
#     for the whole frame, to separate the cost of tiling from that of HTTP.
# Every run uses a fresh scene id (trailing spaces change the bytes, not the
# picture) so no node's result cache or nginx's tile cache answers.  Each
# figure is the median of RUNS runs (default 3).
#
# All nodes share this machine's cores, so more nodes cannot go faster here:
# the table reports overhead and efficiency, not speed-up.  Two measures:
#   wall   wall time over the baseline's, minus 1 (sensitive to whatever else
#          runs on the machine);
#   cpu    CPU seconds spent by the client, every node and nginx's workers
#          (from /proc) over rayd-render's CPU seconds, minus 1: the work the
#          distribution adds, which is what a cluster pays.
# Every client run is paired with a baseline run just before it and the
# ratios are taken per pair, so a load that drifts over minutes cancels out.
# efficiency = baseline CPU / CPU spent; "client" is rayd-client's own CPU
# (scene check, PNG decode, stitch, PNG encode).  docs/operations.md explains what
# the figures mean for a real cluster.
set -eu
cd "$(dirname "$0")/.."
BUILD=$(cd "${1:-build}" && pwd)
RUNS=${RUNS:-3}
SPP=${SPP:-1}
NODE_THREADS=${NODE_THREADS:-2}
TILE=${TILE:-128}
NGINX=$(command -v nginx || echo /usr/sbin/nginx)
tmp=$(mktemp -d "${TMPDIR:-/tmp}/rayd-scaleout.XXXXXX")
pids=()
NGPID=
cleanup() {
    local p
    # TERM first: nginx's master then stops its workers (KILL orphans them)
    if [ -n "$NGPID" ]; then kill -TERM "$NGPID" 2>/dev/null || true; wait "$NGPID" 2>/dev/null || true; fi
    # || true: under set -e a pid that already exited would abort the trap
    # (and make the script exit 1 after a full, good run).
    for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
    wait 2>/dev/null || true
    rm -rf "$tmp"
}
trap cleanup EXIT

echo 0 >"$tmp/seq"
# mkscene OUT: the frame with a fresh id (the counter is a file: callers run
# in subshells)
mkscene() {
    local seq_no=$(($(cat "$tmp/seq") + 1))
    echo "$seq_no" >"$tmp/seq"
    python3 - "$1" "$SPP" "$seq_no" <<'PY'
import json, sys
d = json.load(open("scenes/whitted.json"))
d.setdefault("render", {}).update(width=1920, height=1080, samples=int(sys.argv[2]))
open(sys.argv[1], "w").write(json.dumps(d) + " " * int(sys.argv[3]))
PY
}
now() { date +%s.%N; }
median() { sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }

urls=() nodes=()
for i in 1 2 3; do
    "$BUILD/rayd" --bind 127.0.0.1 --port 0 --threads "$NODE_THREADS" >"$tmp/node$i.out" 2>/dev/null &
    pids+=($!) nodes+=($!)
    for _ in $(seq 1 200); do [ -s "$tmp/node$i.out" ] && break; sleep 0.05; done
    urls+=("$(sed -n 's/^rayd listening on //p' "$tmp/node$i.out")")
done

# nginx on loopback, one configuration per node count (the tests' rewrite)
source tests/integration/lib/nginx.sh
ngstart() { # ngstart N: nginx over the first N nodes; sets LB
    local n=$1 d=$tmp/nginx$1 addrs=() i port
    for ((i = 0; i < n; i++)); do addrs+=("${urls[$i]#http://}"); done
    port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
    nginx_conf "$PWD" "$d" "$port" "${addrs[@]}"
    local g
    g=$(nginx_opts)
    "$NGINX" -p "$d" -c "$d/nginx.conf" -e "$d/log/error.log" -g "$g" 2>/dev/null &
    NGPID=$!
    pids+=($NGPID)
    LB=http://127.0.0.1:$port
    for _ in $(seq 1 100); do curl -s -o /dev/null "$LB/healthz" && break; sleep 0.05; done
}

# cpu_ticks PID...: utime + stime of the processes, in clock ticks
cpu_ticks() {
    local sum=0 p f
    for p in "$@"; do
        [ -r "/proc/$p/stat" ] || continue
        f=$(sed 's/.*) //' "/proc/$p/stat")
        set -- $f
        sum=$((sum + ${12} + ${13}))
    done
    echo "$sum"
}
HZ=$(getconf CLK_TCK)
servers_cpu() { # CPU ticks of the nodes and of nginx's workers
    local w=""
    [ -n "${NGPID:-}" ] && w=$(pgrep -P "$NGPID" -x nginx)
    cpu_ticks "${nodes[@]}" $w
}

# time_client ARGS...: one row's medians: "wall cpu client wall_ratio
# cpu_ratio".  Each run is paired with a rayd-render of the same frame just
# before it, and the ratios are taken per pair: the load other programs put
# on the machine drifts by tens of percent within minutes, a pair sees the
# same load.
time_client() {
    local w=() c=() cl=() rw=() rc=() k c0 c1 bw bcpu
    for k in $(seq "$RUNS"); do
        mkscene "$tmp/s.json"
        /usr/bin/time -f '%e %U %S' -o "$tmp/time" \
            "$BUILD/rayd-render" "$tmp/s.json" -o "$tmp/ref.png" --threads 2
        read -r e u sy <"$tmp/time"
        bw=$e bcpu=$(echo "$u + $sy" | bc -l)
        echo "$bw $bcpu" >>"$tmp/baselines"
        c0=$(servers_cpu)
        /usr/bin/time -f '%e %U %S' -o "$tmp/time" \
            "$BUILD/rayd-client" render "$tmp/s.json" -o "$tmp/out.png" --quiet "$@" ||
            { echo "rayd-client failed" >&2; exit 1; }
        c1=$(servers_cpu)
        read -r e u sy <"$tmp/time"
        w+=("$e")
        c+=("$(echo "$u + $sy + ($c1 - $c0) / $HZ" | bc -l)")
        cl+=("$(echo "$u + $sy" | bc -l)")
        rw+=("$(echo "$e / $bw" | bc -l)")
        rc+=("$(echo "(${c[-1]}) / $bcpu" | bc -l)")
    done
    local m=()
    for v in w c cl rw rc; do
        local -n arr=$v
        m+=("$(printf '%s\n' "${arr[@]}" | median)")
    done
    echo "${m[*]}"
}

tiles_of() { # tiles_of TILE
    echo $(( ((1920 + $1 - 1) / $1) * ((1080 + $1 - 1) / $1) ))
}

row() { # row LABEL NODES TILE "WALL CPU CLIENT WALL_RATIO CPU_RATIO"
    local tiles; tiles=$(tiles_of "$3")
    set -- "$1" "$2" "$3" $4
    awk -v l="$1" -v n="$2" -v tl="$3" -v tiles="$tiles" -v s="$4" -v c="$5" -v cl="$6" \
        -v rw="$7" -v rc="$8" 'BEGIN {
        printf "%-7s %5s %5s %6d %7.2f %8.1f %+8.1f%% %7.2f %6.2f %+8.1f%% %7.0f%%\n", l, n, tl, tiles, s,
               tiles / s, (rw - 1) * 100, c, cl, (rc - 1) * 100, 100 / rc }'
}

: >"$tmp/baselines"
echo "1920x1080 scenes/whitted.json, $SPP spp, median of $RUNS paired runs; nodes --threads $NODE_THREADS, all sharing $(nproc) cores; load average $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-7s %5s %5s %6s %7s %8s %9s %7s %6s %9s %8s\n' mode nodes tile tiles wall_s tiles/s wall_ovh cpu_s client cpu_ovh cpu_eff
for n in 1 2 3; do
    args=()
    for ((i = 0; i < n; i++)); do args+=(--server "${urls[$i]}"); done
    NGPID=
    row direct "$n" "$TILE" "$(time_client "${args[@]}" --tile "$TILE")"
    ngstart "$n"
    row nginx "$n" "$TILE" "$(time_client --server "$LB" --tile "$TILE" --parallel $((4 * n)))"
    kill -QUIT "$NGPID" 2>/dev/null; wait "$NGPID" 2>/dev/null || true
    NGPID=
done
echo "tile size, 1 node direct (tiling cost against one request for the whole frame):"
for tl in 32 64 128 256 1920; do
    row direct 1 "$tl" "$(time_client --server "${urls[0]}" --tile "$tl")"
done
printf 'baseline rayd-render --threads 2 (median of the %d paired runs): %.2f s wall, %.2f s CPU; load average now %s\n' \
    "$(wc -l <"$tmp/baselines")" "$(cut -d' ' -f1 "$tmp/baselines" | median)" \
    "$(cut -d' ' -f2 "$tmp/baselines" | median)" "$(cut -d' ' -f1-3 /proc/loadavg)"
