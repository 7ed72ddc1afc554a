# tests/integration/lib/common.sh -- helpers shared by the integration tests.
# Sourced, never run by tests/run.sh (it only runs tests/integration/*.sh).
#
# Each test script starts its own rayd on 127.0.0.1 with --port 0, reads the
# port from the first stdout line, talks to it with curl, and prints one line
# per case: "PASS name" or "FAIL name: why".  Every process it starts is
# stopped by PID in the EXIT trap.
set -u

RAYD_ROOT=${RAYD_ROOT:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../../.." && pwd)}
RAYD_BUILD=${RAYD_BUILD:-$RAYD_ROOT/build}
RAYD=$RAYD_BUILD/rayd
RENDER=$RAYD_BUILD/rayd-render
T=$(mktemp -d "${TMPDIR:-/tmp}/rayd-it.XXXXXX")
RAYD_PID=
PORT=
URL=
PIDS=()
NFAIL=0

# ours PID: the process is alive and is this script's child.  A PID is only
# a number: once its process has ended and been reaped it is free, and
# where pid_max is 32768 the suite's thousands of short processes wrap it
# within minutes, so an old PID may by now name another test's Redis or
# rayd.  Only our own children are ever signalled by a later cleanup.
ours() {
    local s
    read -r s 2>/dev/null <"/proc/$1/stat" || return 1
    s=${s##*) } # the fields after the command's name: state, ppid, ...
    set -- $s
    [ "${2:-}" = "$$" ]
}

cleanup() {
    local p
    for p in "${PIDS[@]}" $RAYD_PID; do
        ours "$p" && kill -KILL "$p" 2>/dev/null
    done
    wait 2>/dev/null
    rm -rf "$T"
}
trap cleanup EXIT

pass() { echo "PASS $1"; }
fail() { echo "FAIL $1: $2"; NFAIL=$((NFAIL + 1)); }
# check NAME WHY-IF-FALSE COMMAND...: PASS when the command succeeds.
check() {
    local name=$1 why=$2; shift 2
    if "$@"; then pass "$name"; else fail "$name" "$why"; fi
}

# start_rayd [ARGS...]: starts rayd --port 0 on 127.0.0.1 with ARGS; sets
# RAYD_PID, PORT, URL; its stdout/stderr go to $T/rayd.out / $T/rayd.err.
# RAYD_WRAP (e.g. "valgrind --error-exitcode=99") runs it under a tool;
# RAYD_ULIMIT_V limits its address space (KiB, ulimit -v).
start_rayd() {
    : >"$T/rayd.out"
    : >"$T/rayd.err"
    (
        [ -n "${RAYD_ULIMIT_V:-}" ] && ulimit -v "$RAYD_ULIMIT_V"
        exec ${RAYD_WRAP:-} "$RAYD" --bind 127.0.0.1 --port 0 "$@"
    ) >"$T/rayd.out" 2>"$T/rayd.err" &
    RAYD_PID=$!
    local i line=
    for i in $(seq 1 ${RAYD_START_TRIES:-600}); do
        line=$(head -n 1 "$T/rayd.out" 2>/dev/null)
        [ -n "$line" ] && break
        kill -0 "$RAYD_PID" 2>/dev/null || break
        sleep 0.05
    done
    if ! [[ $line =~ ^rayd\ listening\ on\ (https?)://127\.0\.0\.1:([0-9]+)$ ]]; then
        echo "FAIL start_rayd: first line was '$line'"
        cat "$T/rayd.err" >&2
        exit 1
    fi
    PORT=${BASH_REMATCH[2]}
    URL="${BASH_REMATCH[1]}://127.0.0.1:$PORT"
}

# start_node I [ARGS...]: one more rayd, node I of a test that runs several
# (scale-out, balancers, failover), on 127.0.0.1 with --port 0 and ARGS; sets
# NODE_PID[I] and NODE_URL[I], its output in $T/nodeI.out / $T/nodeI.err.
# The output file is emptied before the start: a node started again under
# the same I would otherwise show the last process's line until the new
# one's redirection empties it, which a loaded machine lets a test read.
NODE_PID=() NODE_URL=()
start_node() {
    local i=$1 out=$T/node$1.out line=
    shift
    : >"$out"
    "$RAYD" --bind 127.0.0.1 --port 0 "$@" >"$out" 2>"$T/node$i.err" &
    NODE_PID[$i]=$!
    PIDS+=("${NODE_PID[$i]}")
    wait_until 60 test -s "$out"
    line=$(head -n 1 "$out" 2>/dev/null)
    [[ $line =~ ^rayd\ listening\ on\ (http://127\.0\.0\.1:[0-9]+)$ ]] ||
        { echo "FAIL setup: node $i said '$line'"; exit 1; }
    NODE_URL[$i]=${BASH_REMATCH[1]}
}

# listen_port PID: the port of the TCP socket that process PID listens on
# at 127.0.0.1 (from /proc; empty while it has none).  For servers whose
# stdout cannot be read: no free port is picked first and then raced for.
listen_port() {
    python3 - "$1" <<'PY' 2>/dev/null
import os, sys
pid = sys.argv[1]
inodes = set()
for fd in os.listdir("/proc/%s/fd" % pid):
    try:
        t = os.readlink("/proc/%s/fd/%s" % (pid, fd))
    except OSError:
        continue
    if t.startswith("socket:["):
        inodes.add(t[8:-1])
for line in open("/proc/%s/net/tcp" % pid).readlines()[1:]:
    f = line.split()
    if f[3] == "0A" and f[9] in inodes and f[1].startswith("0100007F:"):
        print(int(f[1].split(":")[1], 16))
        break
PY
}

# raw_answers REQUEST: sends REQUEST (printf-style escapes: \r\n) to rayd
# on one raw connection and prints the status lines that come back
# ("HTTP/1.1 401 HTTP/1.1 200"): for pipelining, Expect and early refusals,
# which curl hides.
raw_answers() {
    python3 - "$PORT" "$1" <<'PY'
import re, socket, sys
s = socket.create_connection(("127.0.0.1", int(sys.argv[1])))
s.sendall(sys.argv[2].encode().decode("unicode_escape").encode("latin-1"))
s.settimeout(60)
got = b""
try:
    while True:
        d = s.recv(65536)
        if not d:
            break
        got += d
except OSError:
    pass
print(" ".join(m.decode() for m in re.findall(rb"HTTP/1\.1 \d{3}", got)))
PY
}

# hold_request NAME READY METHOD PATH [BODY-FILE]: a client that holds its
# request open until the file NAME.stop appears, started in the background
# (its PID in HOLD_PID, and in PIDS).  It sends METHOD PATH to rayd on one
# raw connection (with BODY-FILE as a JSON body); with READY not empty, it
# then reads the answer until READY is in it and writes what it read to
# NAME.ready, so the test knows the answer has begun.  It closes the
# connection once NAME.stop exists: the client leaves when the test says,
# not after a time (60 s at most: that only ends a hung case).
hold_request() {
    python3 - "$PORT" "$@" <<'PY' &
import os, socket, sys, time
port, name, ready, method, path = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5]
body = open(sys.argv[6], "rb").read() if len(sys.argv) > 6 else None
head = "%s %s HTTP/1.1\r\nHost: x\r\n" % (method, path)
if body is not None:
    head += "Content-Type: application/json\r\nContent-Length: %d\r\n" % len(body)
s = socket.create_connection(("127.0.0.1", port), timeout=60)
s.sendall((head + "\r\n").encode() + (body or b""))
if ready:
    got = b""
    while ready.encode() not in got:
        d = s.recv(4096)
        if not d:
            break
        got += d
    open(name + ".ready", "w").write(got.decode("latin-1"))
end = time.time() + 60  # only ends a hung case
while not os.path.exists(name + ".stop") and time.time() < end:
    time.sleep(0.05)
s.close()
PY
    HOLD_PID=$!
    PIDS+=("$HOLD_PID")
}

rayd_gone() { ! kill -0 "$RAYD_PID" 2>/dev/null; }
# stop_rayd [SIGNAL]: signals rayd and waits for it to exit; sets RAYD_RC
# ("hung" when it was still there after RAYD_STOP_SECONDS, 60 by default: a
# bound that only ends a hung test, never a measure of speed).
stop_rayd() {
    local sig=${1:-TERM}
    RAYD_RC=
    [ -n "$RAYD_PID" ] || return 0
    kill -"$sig" "$RAYD_PID" 2>/dev/null
    wait_until "${RAYD_STOP_SECONDS:-60}" rayd_gone
    if kill -0 "$RAYD_PID" 2>/dev/null; then
        kill -KILL "$RAYD_PID" 2>/dev/null
        RAYD_RC=hung
    fi
    wait "$RAYD_PID" 2>/dev/null
    local rc=$?
    [ -n "$RAYD_RC" ] || RAYD_RC=$rc
    # under SANITIZE=1 a report (leak, overflow, UB) fails the script
    if grep -Eq 'ERROR: (Address|Leak)Sanitizer|runtime error:|WARNING: ThreadSanitizer' "$T/rayd.err"; then
        fail sanitizer_report "$(grep -Em 3 'Sanitizer|runtime error' "$T/rayd.err")"
    fi
    RAYD_PID=
}

# wait_until SECONDS COMMAND...: runs COMMAND every 50 ms until it succeeds
# (status 0) or SECONDS have passed (status 1).  Tests wait for a state they
# can observe, never for a time; SECONDS only ends a test that would hang.
wait_until() {
    local end=$(($(date +%s%N) + ${1%.*} * 1000000000)); shift
    until "$@"; do
        [ "$(date +%s%N)" -lt "$end" ] || return 1
        sleep 0.05
    done
}

# The test gate (rayd --test-gate, docs/api.md): workers start a tile only
# when the gate lets one through, so a test holds work in flight for as long
# as it needs, on any machine.
# gate TILES: lets TILES more tiles start (a number, or "open"); the gate's
# state is then in $T/gate.json.
gate() {
    curl -s -m 30 -X POST -o "$T/gate.json" "${AUTH[@]}" "$URL/v1/test/gate?tiles=$1" >/dev/null
}
# gate_read: the gate's state into $T/gate.json (tiles, started, held, queued)
gate_read() { curl -s -m 30 -o "$T/gate.json" "${AUTH[@]}" "$URL/v1/test/gate" >/dev/null; }
# gate_is KEY VALUE: the gate's KEY is VALUE now
gate_is() { gate_read && [ "$(jfield "$T/gate.json" "$1")" = "$2" ]; }
# metric_is NAME VALUE: /metrics has NAME at VALUE (for wait_until)
metric_is() { [ "$(metric "$1")" = "$2" ]; }
# job_is ID KEY VALUE: GET /v1/jobs/ID has KEY at VALUE (body left in $T/body)
job_is() { req GET "/v1/jobs/$1" >/dev/null && [ "$(jfield "$T/body" "$2")" = "$3" ]; }
job_state_is() { job_is "$1" state "$2"; }

# req METHOD PATH [CURL ARGS...]: prints the status code; body in $T/body,
# headers in $T/headers.
req() {
    local method=$1 path=$2; shift 2
    rm -f "$T/body" "$T/headers"
    curl -s -m 60 -X "$method" -o "$T/body" -D "$T/headers" -w '%{http_code}' "$@" "$URL$path"
}
# post_json PATH FILE [CURL ARGS...]
post_json() {
    local path=$1 file=$2; shift 2
    req POST "$path" -H 'Content-Type: application/json' --data-binary @"$file" "$@"
}
header() { # header NAME: value of a response header in $T/headers
    grep -i "^$1:" "$T/headers" | head -n 1 | sed 's/^[^:]*: *//; s/\r$//'
}
# json FILE EXPR: evaluates a python expression on the parsed JSON (as j)
json() {
    python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))' "$1" "$2" 2>/dev/null
}
# jfield FILE KEY: a top-level string or number field, without python (fast)
jfield() {
    sed -n 's/.*"'"$2"'":"\{0,1\}\([^",}]*\).*/\1/p' "$1" | head -n 1
}
# err_is FILE STATUS CODE [PATH]: the body is the API's JSON error with them
err_is() {
    python3 - "$@" <<'PY' 2>/dev/null
import json, sys
f, status, code = sys.argv[1], int(sys.argv[2]), sys.argv[3]
e = json.load(open(f))["error"]
ok = e["status"] == status and e["code"] == code and isinstance(e.get("message"), str) and e["message"]
if len(sys.argv) > 4:
    ok = ok and e.get("path") == sys.argv[4]
sys.exit(0 if ok else 1)
PY
}
# True for a sanitizer build of rayd (ASan or TSan), which renders several
# times slower: tests that need a render to last pick their sizes by it.
sanitized() { ldd "$RAYD" 2>/dev/null | grep -Eq 'lib(a|t)san'; }

is_png() { [ "$(head -c 8 "$1" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a ]; }
png_size() { # png_size FILE: "WxH" from the IHDR
    python3 -c 'import struct,sys; d=open(sys.argv[1],"rb").read(24); print("%dx%d" % struct.unpack(">II", d[16:24]))' "$1"
}
metric() { # metric NAME_WITH_LABELS: current value from /metrics
    curl -s -m 60 "$URL/metrics" "${AUTH[@]}" | awk -v k="$1" '$1 == k {print $2}'
}
# The bytes --max-memory counts now: rayd_memory_bytes summed over its kinds.
memory_total() {
    local k sum=0 v
    for k in bodies scenes results sums caches parses frames; do
        v=$(metric "rayd_memory_bytes{kind=\"$k\"}")
        sum=$((sum + ${v:-0}))
    done
    echo "$sum"
}
rayd_rss() { awk '/^VmRSS:/ {print $2 * 1024}' "/proc/$RAYD_PID/status"; } # resident bytes
AUTH=()
# PYTHONPATH for the scripts' Python that reads event streams (sse.py)
SSE_LIB=$RAYD_ROOT/tests/integration/lib

# scene OUT WIDTH HEIGHT [SAMPLES] [BASE] [TAG]: a variant of a stock scene;
# TAG changes the bytes (and so the id) without changing the picture.
scene() {
    python3 - "$@" <<'PY'
import json, sys
out, w, h = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
samples = int(sys.argv[4]) if len(sys.argv) > 4 else 1
base = sys.argv[5] if len(sys.argv) > 5 else "spheres"
tag = sys.argv[6] if len(sys.argv) > 6 else ""
import os
root = os.environ.get("RAYD_ROOT", ".")
s = json.load(open(os.path.join(root, "tests/scenes", base + ".json")))
s["render"]["width"], s["render"]["height"], s["render"]["samples"] = w, h, samples
open(out, "w").write(json.dumps(s, indent=1) + " " * (int(tag) if tag.isdigit() else 0) + "\n")
PY
}
