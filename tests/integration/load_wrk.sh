#!/usr/bin/env bash
# load_wrk.sh -- the 256-connection load test, bounded: wrk (Debian) with
# 256 connections for 8 s of distinct 64x64 renders on loopback.  Every
# answer must be a PNG or a 503 with Retry-After, no socket error, some
# PNGs served, and the server's peak RSS bounded.  (`make bench` runs the
# same for 60 s and reports latency: bench/http.sh.)
# rayd-test: alone
source "$(dirname "$0")/lib/common.sh"
if ! command -v wrk >/dev/null; then
    check wrk_installed "wrk is missing (make test-deps installs it)" false
    exit 0
fi
python3 - "$T/scene.json" <<'PY'
import json, sys
s = json.load(open("tests/scenes/spheres.json"))
s["render"].update(width=256, height=256, samples=1)
open(sys.argv[1], "w").write(json.dumps(s))
PY
start_rayd --result-cache-mb 0
wrk -t2 -c256 -d8s --timeout 20s -s "$RAYD_ROOT/bench/http.lua" "$URL" -- "$T/scene.json" 64 256 256 any \
    >"$T/wrk.out" 2>&1
line=$(sed -n 's/^RESULT //p' "$T/wrk.out")
check wrk_ran "no RESULT line: $(head -c 300 "$T/wrk.out")" [ -n "$line" ]
check load256_only_png_or_503 "$line" python3 -c '
import sys
kv = dict(w.split("=") for w in sys.argv[1].split())
bad = sum(int(v) for k, v in kv.items() if k.startswith("s") and k[1:].isdigit() and k not in ("s200", "s503"))
bad += int(kv["bad503"]) + sum(int(kv[k]) for k in ("connect_err", "read_err", "write_err", "timeout_err"))
sys.exit(1 if bad or int(kv.get("s200", 0)) == 0 else 0)' "$line"
hwm=$(awk '$1 == "VmHWM:" {print $2}' "/proc/$RAYD_PID/status")
limit=262144 # 256 MiB; sanitizer builds keep shadow memory and quarantine
case "$RAYD_BUILD" in */asan | */tsan) limit=2097152 ;; esac
check load256_rss_bounded "VmHWM ${hwm} kB, limit ${limit} kB" [ "${hwm:-999999999}" -lt "$limit" ]
check load256_alive_after "healthz" [ "$(curl -s -o /dev/null -w '%{http_code}' "$URL/healthz")" = 200 ]
