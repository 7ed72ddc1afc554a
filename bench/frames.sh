#!/usr/bin/env bash
# bench/frames.sh BUILD -- a shot end to end through the server: scenes/
# animation.json's first 100 frames (the scene has 48: its range is
# stretched to 0-99 here, the keyframes kept) at 320x180, one
# POST /v1/jobs?frames=0-99 followed to its end, then its video fetched.
# Once by a rayd in memory and once with --data-dir (each frame written,
# fsynced, renamed, its row committed), RUNS (default 1) runs each,
# medians; also rayd-render --frames 0-99 on the same threads, the floor.
# Prints the seconds to the last frame done, per frame, and the video's.
# Run by bench/run.sh (`make bench`).  DATA (default a folder under
# build/) is where --data-dir goes: put it on a real disk for a real fsync.
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
RUNS=${RUNS:-1}
THREADS=${THREADS:-2}
DATA=${DATA:-$BUILD/bench-frames-data}
T=$(mktemp -d)
RPID=
cleanup() { [ -n "$RPID" ] && kill "$RPID" 2>/dev/null; wait 2>/dev/null; rm -rf "$T" "$DATA"; }
trap cleanup EXIT

python3 - "$T/shot.json" <<'PY'
import json, sys
s = json.load(open("scenes/animation.json"))
s["animation"]["end"] = 99
s["render"]["width"], s["render"]["height"] = 320, 180
json.dump(s, open(sys.argv[1], "w"))
PY

start() { # start ARGS...: a rayd on a free port; its URL in $URL
    "$BUILD/rayd" --bind 127.0.0.1 --port 0 --threads "$THREADS" "$@" >"$T/out" 2>/dev/null &
    RPID=$!
    URL=
    for _ in $(seq 1 200); do
        URL=$(sed -n 's/^rayd listening on //p' "$T/out")
        [ -n "$URL" ] && return 0
        sleep 0.05
    done
    echo "bench/frames.sh: rayd did not start"
    exit 1
}

# one_run: POST the shot, poll to its end, fetch the video; "FRAMES_S VIDEO_S"
one_run() {
    python3 - "$URL" "$T/shot.json" <<'PY'
import json, sys, time, urllib.request
url, scene = sys.argv[1], open(sys.argv[2], "rb").read()
t0 = time.monotonic()
req = urllib.request.Request(url + "/v1/jobs?frames=0-99", data=scene,
                             headers={"Content-Type": "application/json"})
job = json.load(urllib.request.urlopen(req))["id"]
while True:
    j = json.load(urllib.request.urlopen(url + "/v1/jobs/" + job))
    if j["state"] in ("succeeded", "failed", "canceled"):
        break
    time.sleep(0.01)
t1 = time.monotonic()
assert j["state"] == "succeeded", j
while True:
    try:
        r = urllib.request.urlopen(url + "/v1/jobs/%s/video.mp4" % job)
        if r.status == 200:
            r.read()
            break
    except urllib.error.HTTPError as e:
        if e.code != 202:
            raise
    time.sleep(0.01)
print("%.3f %.3f" % (t1 - t0, time.monotonic() - t1))
PY
}

median() { sort -n | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }

echo "-- 100 frames of scenes/animation.json at 320x180, $THREADS threads (median of $RUNS runs)"
printf '%-24s %12s %14s %12s\n' "" "frames s" "ms a frame" "video s"
for mode in memory data-dir; do
    : >"$T/runs"
    for _ in $(seq 1 "$RUNS"); do
        rm -rf "$DATA"
        if [ "$mode" = data-dir ]; then start --data-dir "$DATA"; else start; fi
        one_run >>"$T/runs"
        kill "$RPID"
        wait "$RPID" 2>/dev/null || true
        RPID=
    done
    f=$(cut -d' ' -f1 "$T/runs" | median)
    v=$(cut -d' ' -f2 "$T/runs" | median)
    printf '%-24s %12s %14.1f %12s\n' "rayd ($mode)" "$f" "$(echo "$f * 10" | bc -l)" "$v"
done
: >"$T/runs"
for _ in $(seq 1 "$RUNS"); do
    s=$(date +%s.%N)
    "$BUILD/rayd-render" "$T/shot.json" --frames 0-99 -o "$T/f-%04d.png" --threads "$THREADS" -q
    echo "$(date +%s.%N) - $s" | bc -l >>"$T/runs"
done
f=$(median <"$T/runs")
printf '%-24s %12.3f %14.1f %12s\n' "rayd-render --frames" "$f" "$(echo "$f * 10" | bc -l)" "-"
