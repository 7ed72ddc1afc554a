#!/usr/bin/env bash
# bench/http.sh BUILD -- HTTP load on a real rayd over loopback with wrk
# (Debian), run by bench/run.sh (`make bench`).
#
#   1. 256 connections for HTTP_BENCH_SECONDS (60) POSTing 64x64 regions at
#      random pixel offsets of a small scene (256x256, the spheres test scene,
#      1 sample), with the result cache off, so nearly every request is a
#      distinct render and the queue fills: requests/s, p50/p99
#      latency, every status counted; the only failures allowed are 503 with
#      Retry-After (the queue is full: back-pressure); RSS sampled from
#      /proc/PID/status during the run (max VmRSS) and VmHWM at the end.
#   2. issue 3's figure: 16 connections, 64x64 tiles of the same scene, for
#      HTTP_BENCH_TILE_SECONDS (20), cache off and then on (default server).
# Prints one line per run and exits non-zero if a run had a failure.
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
SECS=${HTTP_BENCH_SECONDS:-60}
TSECS=${HTTP_BENCH_TILE_SECONDS:-20}
command -v wrk >/dev/null || { echo "bench/http.sh: wrk not installed (make test-deps)"; exit 1; }
T=$(mktemp -d)
RPID=
cleanup() { [ -n "$RPID" ] && kill "$RPID" 2>/dev/null; wait 2>/dev/null; rm -rf "$T"; }
trap cleanup EXIT

python3 - "$T/scene.json" <<'PY'
import json, sys
s = json.load(open("tests/scenes/spheres.json"))
s["render"].update(width=256, height=256, samples=1)
open(sys.argv[1], "w").write(json.dumps(s))
PY

start() { # ARGS...: starts rayd, sets RPID and URL
    "$BUILD/rayd" --bind 127.0.0.1 --port 0 "$@" >"$T/out" 2>/dev/null &
    RPID=$!
    for _ in $(seq 1 100); do
        URL=$(sed -n 's/^rayd listening on //p' "$T/out")
        [ -n "$URL" ] && break
        sleep 0.05
    done
    [ -n "$URL" ]
}
stop() { kill -TERM "$RPID"; wait "$RPID" || true; RPID=; }
mb() { awk -v k="$1" 'BEGIN {print k / 1024}'; }
rss_kb() { awk -v k="$2:" '$1 == k {print $2}' "/proc/$1/status"; }

run() { # NAME CONNS SECONDS TILE [any]
    local name=$1 conns=$2 secs=$3 tile=$4 where=${5:-grid} idle peak=0 r hwm line
    idle=$(rss_kb "$RPID" VmRSS)
    wrk -t2 -c"$conns" -d"${secs}s" --timeout 30s -s bench/http.lua "$URL" -- "$T/scene.json" "$tile" 256 256 "$where" \
        >"$T/wrk.out" 2>&1 &
    local wp=$!
    while kill -0 "$wp" 2>/dev/null; do
        r=$(rss_kb "$RPID" VmRSS)
        [ "${r:-0}" -gt "$peak" ] && peak=$r
        sleep 0.5
    done
    wait "$wp" || { cat "$T/wrk.out"; return 1; }
    hwm=$(rss_kb "$RPID" VmHWM)
    line=$(sed -n 's/^RESULT //p' "$T/wrk.out")
    printf '%-28s conns=%d secs=%d %s rss_idle_mb=%.1f rss_max_mb=%.1f vmhwm_mb=%.1f\n' "$name" "$conns" "$secs" \
        "$line" "$(mb "$idle")" "$(mb "$peak")" "$(mb "$hwm")"
    # failures: any status but 200 and 503, a 503 without Retry-After, socket errors
    echo "$line" | python3 -c '
import sys
kv = dict(w.split("=") for w in sys.stdin.read().split())
bad = sum(int(v) for k, v in kv.items() if k.startswith("s") and k[1:].isdigit() and k not in ("s200", "s503"))
bad += int(kv["bad503"]) + sum(int(kv[k]) for k in ("connect_err", "read_err", "write_err", "timeout_err"))
sys.exit(1 if bad or int(kv.get("s200", 0)) == 0 else 0)' || { echo "  FAILED: requests other than 200 / 503+Retry-After"; FAILED=1; }
}

FAILED=0
start --result-cache-mb 0
run "256conns-any64-nocache" 256 "$SECS" 64 any
stop
start --result-cache-mb 0
run "16conns-64px-tiles-nocache" 16 "$TSECS" 64
stop
start
run "16conns-64px-tiles-cached" 16 "$TSECS" 64
stop
exit $FAILED
