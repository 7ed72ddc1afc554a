#!/usr/bin/env bash
# faults.sh -- faults with nothing lost and nothing crashed:
#   * SIGTERM during load: every request the server accepted is answered (a
#     PNG or a 503 with Retry-After), every job reports done; sent = answered
#     + refused at connect or while sending (closed before the request was
#     read), none silently lost;
#   * allocation failure in the core: a mesh scene too large for the memory
#     rayd may use (ulimit -v; under ASan its allocator returns NULL past a
#     size) fails cleanly with 503 out_of_memory naming the stage that
#     failed (body, parse, base64, PLY, BVH), and the server goes on;
#   * a client that closes its socket in the middle of a large response;
#   * the access log on a full disk (stderr = /dev/full), stdout closed,
#     stderr closed: write errors never stop the server.
source "$(dirname "$0")/lib/common.sh"

sanitized=
if ldd "$RAYD" 2>/dev/null | grep -Eq 'lib(asan|tsan)'; then sanitized=$(ldd "$RAYD" | grep -Eo 'lib(asan|tsan)' | head -n 1); fi
[ -n "${RAYD_WRAP:-}" ] && sanitized=valgrind

# --- SIGTERM during load ----------------------------------------------------------------------
scene "$T/load.json" 192 128 2 spheres
cat >"$T/load.py" <<'PY'
import http.client, json, socket, sys, threading, time
port, scene, nthreads, out = int(sys.argv[1]), open(sys.argv[2], "rb").read(), int(sys.argv[3]), sys.argv[4]
lock = threading.Lock()
tally = {"sent": 0, "ok": 0, "busy": 0, "draining": 0, "refused": 0, "lost": 0, "other": 0}
lost = []
def add(k, note=None):
    with lock:
        tally[k] += 1
        if note:
            lost.append(note)
def worker(i):
    n = 0
    while True:
        q = "?x=%d&y=%d&w=64&h=64" % (64 * (n % 3), 64 * ((n // 3) % 2)) if n % 4 else ""
        n += 1
        c = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
        try:
            c.connect()
        except OSError:
            add("refused")
            return
        try:
            c.request("POST", "/v1/render" + q, body=scene, headers={"Content-Type": "application/json"})
        except OSError:
            # the server closed the connection before it read the request
            # (it is shutting down): never accepted, and the client knows
            c.close()
            add("refused")
            return
        add("sent")
        try:
            r = c.getresponse()
            body = r.read()
        except Exception as e:
            add("lost", "thread %d: %r" % (i, e))
            return
        finally:
            c.close()
        if r.status == 200 and body[:4] == b"\x89PNG":
            add("ok")
            if tally["ok"] == 10:
                open(out + ".served", "w").close()
        elif r.status == 503 and r.getheader("Retry-After"):
            code = json.loads(body)["error"]["code"]
            if code == "draining":
                add("draining")
                return  # the server is going away: stop, as a client would
            add("busy")
            time.sleep(0.02)
        else:
            add("other", "thread %d: %d %r" % (i, r.status, body[:100]))
ts = [threading.Thread(target=worker, args=(i,)) for i in range(nthreads)]
for t in ts:
    t.start()
open(out + ".started", "w").close()
for t in ts:
    t.join()
json.dump({"tally": tally, "lost": lost}, open(out, "w"))
PY
start_rayd --threads 2 --queue 4 --drain-seconds 20 --result-cache-mb 0
# a few asynchronous jobs, followed by their event streams
for k in 1 2 3; do
    scene "$T/job$k.json" 320 240 8 spheres "$k"
    post_json /v1/jobs "$T/job$k.json" >/dev/null
    jid=$(jfield "$T/body" id)
    curl -s -N -m 60 "$URL/v1/jobs/$jid/events" >"$T/sse$k.txt" &
    PIDS+=($!)
    sse+=($!)
done
python3 "$T/load.py" "$PORT" "$T/load.json" 12 "$T/tally.json" &
lp=$!
PIDS+=($lp)
# TERM once the server is busy serving the load (ten PNGs out), however
# long that takes on this machine
wait_until 120 test -e "$T/tally.json.served"
stop_rayd TERM
check sigterm_load_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
wait "$lp"
wait "${sse[@]}"
summary=$(python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); print(" ".join("%s=%s" % kv for kv in d["tally"].items()), d["lost"][:3])' "$T/tally.json")
echo "sigterm under load: $summary"
check sigterm_load_none_lost "$summary" python3 -c '
import json, sys
t = json.load(open(sys.argv[1]))["tally"]
sys.exit(0 if t["lost"] == 0 and t["other"] == 0 and t["sent"] == t["ok"] + t["busy"] + t["draining"] and t["ok"] > 0 and (t["draining"] > 0 or t["refused"] > 0) else 1)' "$T/tally.json"
check sigterm_jobs_reported "$(tail -n 3 "$T"/sse*.txt | tr '\n' ' ' | head -c 400)" bash -c "
for k in 1 2 3; do grep -A1 '^event: done' '$T/sse'\$k.txt | grep -Eq '\"state\":\"(succeeded|canceled)\"' || exit 1; done"

# --- allocation failure in the core -------------------------------------------------------------
# a 1.3-million-triangle mesh (base64 PLY in the body, 33 MB) at five memory
# ceilings, each failing at a different allocation (the body, the parse, the
# base64 decode, the PLY arrays, the BVH)
"$RAYD_BUILD/bench/genmesh" 8 "$T/mesh8.ply" >/dev/null 2>&1 || "$RAYD_ROOT/build/bench/genmesh" 8 "$T/mesh8.ply" >/dev/null 2>&1
python3 - "$T/mesh8.ply" "$T/big.json" <<'PY'
import base64, json, sys
d = open(sys.argv[1], "rb").read()
s = {"camera": {"position": [0, 0, 4], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_x": 50},
     "render": {"width": 32, "height": 24, "samples": 1, "max_depth": 1},
     "lights": [{"type": "point", "position": [5, 5, 5]}],
     "objects": [{"type": "mesh", "source": {"format": "ply", "base64": base64.b64encode(d).decode()},
                  "smooth": False}]}
open(sys.argv[2], "w").write(json.dumps(s))
PY
scene "$T/tiny.json" 32 24 1 spheres
oom_case() { # name [STAGE]: POST the big scene, expect 503 out_of_memory naming STAGE, then the server still serves
    local name=$1 stage=${2:-} code
    code=$(post_json /v1/render "$T/big.json")
    check "oom_${name}_503" "status $code $(head -c 200 "$T/body")" err_is "$T/body" 503 out_of_memory
    [ -z "$stage" ] || check "oom_${name}_stage" "not '$stage': $(head -c 200 "$T/body")" grep -q "$stage" "$T/body"
    check "oom_${name}_retry_after" "no Retry-After" [ -n "$(header Retry-After)" ]
    echo "oom $name: $(head -c 200 "$T/body")"
    check "oom_${name}_alive" "healthz" [ "$(req GET /healthz)" = 200 ]
    code=$(post_json /v1/render "$T/tiny.json")
    check "oom_${name}_still_renders" "status $code $(head -c 200 "$T/body" | tr -d '\0')" bash -c "[ $code = 200 ] && head -c 4 '$T/body' | grep -q PNG"
    stop_rayd TERM
    check "oom_${name}_exit_0" "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
}
if [ ! -s "$T/mesh8.ply" ]; then
    fail oom_mesh "genmesh did not run"
elif [ "$sanitized" = libasan ]; then
    # ASan reserves terabytes of shadow memory, so no ulimit -v: its allocator
    # returns NULL for any single allocation over 16 MiB instead
    ASAN_OPTIONS=${ASAN_OPTIONS:+$ASAN_OPTIONS:}allocator_may_return_null=1:max_allocation_size_mb=16 \
        start_rayd --threads 2 --max-body 67108864
    oom_case asan_16mb
elif [ -z "$sanitized" ]; then
    # one malloc arena: glibc reserves 64 MiB of address space for each
    # thread's arena when it can align the mapping, which depends on where
    # the kernel puts it, so with several the room left for the small render
    # after the failure (and the stage that fails) would change from run to
    # run. Each ceiling sits mid-way in the range where its stage fails
    # (rayd starts at about 92 MB: thread stacks and the preview's files).
    for case in "112000 reading the body" "142000 parsing the scene" "169000 base64:" \
        "196000 PLY header:" "244000 building the BVH"; do
        kb=${case%% *}
        MALLOC_ARENA_MAX=1 RAYD_ULIMIT_V=$kb start_rayd --threads 2 --max-body 67108864
        oom_case "ulimit_${kb}k" "${case#* }"
    done
else
    echo "SKIP oom cases under $sanitized (no address-space limit possible)"
fi

# --- a client that closes its socket during a large response -----------------------------------
start_rayd --threads 2
scene "$T/large.json" 1280 960 1 spheres
code=$(post_json /v1/render "$T/large.json")
size=$(wc -c <"$T/body")
check large_response_rendered "status $code, $size bytes" bash -c "[ $code = 200 ] && [ $size -gt 200000 ]"
python3 - "$PORT" "$T/large.json" >"$T/cut.txt" <<'PY'
import socket, struct, sys, threading
port, body = int(sys.argv[1]), open(sys.argv[2], "rb").read()
req = (b"POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
       b"Content-Length: %d\r\n\r\n" % len(body)) + body
def cut(i):
    s = socket.create_connection(("127.0.0.1", port), timeout=30)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    s.sendall(req)
    got = s.recv(2000 + 100 * i)
    if i % 2:  # abortive close: RST while the server is writing
        s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    s.close()
    res[i] = len(got) > 0
res = [None] * 20
ts = [threading.Thread(target=cut, args=(i,)) for i in range(20)]
for t in ts: t.start()
for t in ts: t.join()
for r in res: print("cut", r)
PY
check cut_clients_got_bytes "$(sort "$T/cut.txt" | uniq -c | tr '\n' ' ')" bash -c "[ \$(grep -c 'cut True' '$T/cut.txt') = 20 ]"
check cut_server_alive "healthz" [ "$(req GET /healthz)" = 200 ]
code=$(post_json /v1/render "$T/large.json")
check cut_then_full_response "status $code, $(wc -c <"$T/body") bytes" bash -c "[ $code = 200 ] && [ \$(wc -c <'$T/body') = $size ]"
stop_rayd TERM
check cut_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- the access log on a full disk; stdout or stderr closed --------------------------------------
# rayd's stdout may be closed here, so its port is read from /proc (--port
# 0: no free port picked first and raced for with other programs)
rayd_port() { port=$(listen_port "$RAYD_PID"); [ -n "$port" ]; }
io_case() { # name, redirections as a string
    local name=$1 redir=$2 port= code ok=1 k
    eval "\"\$RAYD\" --bind 127.0.0.1 --port 0 --threads 2 $redir &"
    RAYD_PID=$!
    if ! wait_until 60 rayd_port ||
        ! wait_until 60 curl -s -m 5 -o /dev/null "http://127.0.0.1:$port/healthz"; then
        fail "io_${name}_up" "rayd did not come up"
        kill -KILL "$RAYD_PID" 2>/dev/null
        RAYD_PID=
        return
    fi
    for k in 1 2 3 4 5; do
        code=$(curl -s -m 30 -o "$T/io.png" -w '%{http_code}' -H 'Content-Type: application/json' \
            --data-binary @"$T/tiny.json" "http://127.0.0.1:$port/v1/render")
        [ "$code" = 200 ] && is_png "$T/io.png" || ok=0
        code=$(curl -s -m 60 -o "$T/io.txt" -w '%{http_code}' "http://127.0.0.1:$port/nope")
        [ "$code" = 404 ] && err_is "$T/io.txt" 404 not_found || ok=0
    done
    check "io_${name}_serves" "a request failed" [ "$ok" = 1 ]
    kill -TERM "$RAYD_PID"
    wait "$RAYD_PID"
    check "io_${name}_exit_0" "exit status $?" [ $? = 0 ]
    RAYD_PID=
}
io_case stderr_full '>"$T/io.out" 2>/dev/full'
io_case stdout_full '>/dev/full 2>"$T/io.err"'
check io_stdout_full_warned "no warning" grep -q 'cannot write the listening line' "$T/io.err"
io_case stdout_closed '>&- 2>"$T/io.err"'
io_case stderr_closed '>"$T/io.out" 2>&-'
io_case both_closed '>&- 2>&-'
io_case stderr_pipe_gone '>"$T/io.out" 2> >(head -c 10 >/dev/null)'
