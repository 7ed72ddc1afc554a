#!/usr/bin/env bash
# bench/durable.sh BUILD -- what --data-dir costs a job (issue 41): the same
# N small jobs (distinct 64x64 scenes, 1 sample: the render is cheap, so the
# store's share shows) posted one after another and followed to their end,
# by a rayd in memory and by a rayd with --data-dir (SQLite WAL,
# synchronous=FULL; each image written, fsynced, renamed, folder fsynced).
# Prints, for each, the POST's latency (with --data-dir the 202 waits for
# the job's record to be committed) and the time from the first POST to the
# last job succeeded, per job.  Run by bench/run.sh (`make bench`); N
# (default 200) jobs, RUNS (default 3) runs each, medians.  DATA (default
# a folder under build/) is where --data-dir goes: put it on the disk the
# server would use, not on a tmpfs, for a real fsync.
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
N=${N:-200}
RUNS=${RUNS:-3}
DATA=${DATA:-$BUILD/bench-data}
T=$(mktemp -d)
RPID=
cleanup() { [ -n "$RPID" ] && kill "$RPID" 2>/dev/null; wait 2>/dev/null; rm -rf "$T" "$DATA"; }
trap cleanup EXIT

start() { # start ARGS...: a rayd on a free port; its URL in $URL
    "$BUILD/rayd" --bind 127.0.0.1 --port 0 --threads 2 --result-cache-mb 0 --max-jobs 100000 \
        "$@" >"$T/out" 2>/dev/null &
    RPID=$!
    URL=
    for _ in $(seq 1 200); do
        URL=$(sed -n 's/^rayd listening on //p' "$T/out")
        [ -n "$URL" ] && return 0
        sleep 0.05
    done
    echo "bench/durable.sh: rayd did not start"
    exit 1
}

echo "-- $N jobs of 64x64, 1 sample, posted one after another (median of $RUNS runs)"
printf '%-22s %14s %14s %16s\n' "rayd" "POST p50 ms" "POST p99 ms" "ms a job, end"
for mode in memory data-dir; do
    for r in $(seq 1 "$RUNS"); do
        rm -rf "$DATA"
        if [ "$mode" = memory ]; then start; else start --data-dir "$DATA"; fi
        python3 - "$URL" "$N" "$r" >>"$T/$mode" <<'PY'
import json, sys, time, urllib.request
url, n, run = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
base = json.load(open("scenes/spheres.json"))
base["render"].update(width=64, height=64, samples=1)
lat, ids = [], []
t0 = time.monotonic()
for i in range(n):
    body = (json.dumps(base) + " " * (i + 1 + run * n)).encode()  # a scene id of its own
    req = urllib.request.Request(url + "/v1/jobs", body, {"Content-Type": "application/json"})
    a = time.monotonic()
    with urllib.request.urlopen(req) as r:
        ids.append(json.load(r)["id"])
    lat.append((time.monotonic() - a) * 1e3)
left = set(ids)
while left:
    for i in list(left)[:50]:
        with urllib.request.urlopen(url + "/v1/jobs/" + i) as r:
            if json.load(r)["state"] == "succeeded":
                left.discard(i)
    time.sleep(0.01)
total = (time.monotonic() - t0) * 1e3
lat.sort()
print("%.3f %.3f %.3f" % (lat[len(lat) // 2], lat[min(len(lat) - 1, int(len(lat) * 0.99))], total / n))
PY
        kill "$RPID"; wait "$RPID" 2>/dev/null || true; RPID=
    done
    python3 - "$T/$mode" "$mode" <<'PY'
import sys, statistics
rows = [list(map(float, l.split())) for l in open(sys.argv[1])]
med = [statistics.median(c) for c in zip(*rows)]
print("%-22s %14.3f %14.3f %16.3f" % (sys.argv[2], *med))
PY
done
echo "(data dir on $(df -P "$BUILD" | awk 'NR==2 {print $1}'), $(nproc) cores)"
