#!/usr/bin/env bash
# client_progressive.sh -- rayd-client render --progressive and watch ID.
#
# Against a real rayd, with the passes held by the test gate: each pass is
# in -o while the next one waits (the server's own pass image, byte for
# byte), the end is the job's final image and exit 0; SIGINT cancels the
# job and leaves -o with the last whole pass (exit 130); --detach leaves
# the job running and watch ID follows it to its end, and SIGINT in watch
# leaves the job running.  Against a fake server: an event stream that
# breaks is opened again, one that keeps ending without news gives way to
# polling, and a hostile server's wrong image size, absurd pass figures
# and terminal escapes are refused (nothing written, the job cancelled).
source "$(dirname "$0")/lib/common.sh"
CLIENT=$RAYD_BUILD/rayd-client

start_rayd --threads 2 --test-gate open
scene "$T/p8.json" 128 64 8 cornell # two 64x64 tiles a pass; passes of 1, 2, 4, 8 samples
for n in 1 2; do
    scene "$T/p$n.json" 128 64 $n cornell
    code=$(post_json /v1/render "$T/p$n.json")
    cp "$T/body" "$T/ref$n.png"
    check "ref_${n}_rendered" "status $code" [ "$code" = 200 ]
done

# start_client NAME ARGS...: rayd-client in the background, stderr in $T/NAME.log,
# stdout in $T/NAME.out; its PID in CPID
start_client() {
    local name=$1
    shift
    "$CLIENT" "$@" >"$T/$name.out" 2>"$T/$name.log" &
    CPID=$!
    PIDS+=("$CPID")
}
# client_rc: waits for CPID; its status in CRC
client_rc() {
    wait "$CPID"
    CRC=$?
}
logged() { grep -q "$2" "$T/$1.log"; }             # logged NAME TEXT
job_of() { sed -n 's/^rayd-client: job \([0-9a-f]\{32\}\) .*/\1/p' "$T/$1.log" | head -n 1; }

# --- to the end: each pass in -o while the next one is held, then the final image --------------
gate 0
start_client run render --progressive "$T/p8.json" -o "$T/run.png" --server "$URL"
gate 2 # pass 1's two tiles
wait_until 60 logged run 'pass 1/4: 1/8 samples'
id=$(job_of run)
wait_until 30 gate_is held 2
code=$(req GET "/v1/jobs/$id/image.png?pass=1")
check run_pass1_written "status $code: $(cat "$T/run.log")" bash -c \
    "[ $code = 200 ] && cmp -s '$T/run.png' '$T/body' && cmp -s '$T/run.png' '$T/ref1.png'"
gate 2
wait_until 60 logged run 'pass 2/4: 2/8 samples'
wait_until 30 gate_is held 2
code=$(req GET "/v1/jobs/$id/image.png?pass=2")
check run_pass2_written "status $code: $(tail -n 2 "$T/run.log")" bash -c \
    "[ $code = 200 ] && cmp -s '$T/run.png' '$T/body' && cmp -s '$T/run.png' '$T/ref2.png'"
check run_no_temp_left "$(ls "$T")" bash -c "! ls '$T' | grep -q 'run.png.*part'"
gate open
client_rc
code=$(req GET "/v1/jobs/$id/image.png")
check run_exit_0 "exit $CRC: $(cat "$T/run.log")" [ "$CRC" = 0 ]
check run_final_equals_job_image "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/run.png'"
check run_lines "$(cat "$T/run.log")" bash -c "grep -c '^rayd-client: pass [1-4]/4: ' '$T/run.log' | grep -qx 4 && \
    grep -q 'pass 4/4: 8/8 samples, [0-9.]*s, ETA 0s -> $T/run.png' '$T/run.log' && grep -q 'succeeded; wrote' '$T/run.log'"

# --- stopped early (POST /stop): exit 0, and the last line says at which pass and why -------------
gate 0
start_client stop render --progressive "$T/p8.json" -o "$T/stop.png" --server "$URL"
gate 2
wait_until 60 logged stop 'pass 1/4'
id=$(job_of stop)
wait_until 30 gate_is held 2
code=$(req POST "/v1/jobs/$id/stop")
gate open
client_rc
check stop_says_why "status $code, exit $CRC: $(cat "$T/stop.log")" bash -c "[ $code = 200 ] && \
    [ $CRC = 0 ] && grep -q 'job $id succeeded, stopped at pass [12] of 4 ([12] of 8 samples) by a stop request (POST /v1/jobs/ID/stop); wrote $T/stop.png' '$T/stop.log'"

# --- SIGINT mid-job: cancelled, -o keeps the last whole pass, exit 130 ---------------------------
gate 0
start_client int render --progressive "$T/p8.json" -o "$T/int.png" --server "$URL"
gate 2
wait_until 60 logged int 'pass 1/4'
id=$(job_of int)
wait_until 30 gate_is held 2
kill -INT "$CPID"
client_rc
check int_exit_130 "exit $CRC: $(cat "$T/int.log")" [ "$CRC" = 130 ]
check int_job_cancelled "state $(jfield "$T/body" state)" wait_until 30 job_state_is "$id" canceled
check int_keeps_last_pass "$(cat "$T/int.log")" cmp -s "$T/int.png" "$T/ref1.png"
check int_says_so "$(cat "$T/int.log")" bash -c "grep -q 'job $id cancelled' '$T/int.log' && \
    grep -q 'int.png holds pass 1 of 4 (1 samples)' '$T/int.log'"
gate open

# --- --detach, then watch ID: it finishes what render started; SIGINT in watch detaches --------
gate 0
"$CLIENT" render --progressive --detach "$T/p8.json" -o "$T/w.png" --server "$URL" >"$T/detach.out" 2>"$T/detach.log"
rc=$?
id=$(cat "$T/detach.out")
check detach_prints_id "exit $rc, '$id': $(cat "$T/detach.log")" bash -c \
    "[ $rc = 0 ] && [[ '$id' =~ ^[0-9a-f]{32}$ ]] && [ ! -e '$T/w.png' ] && grep -q 'rayd-client watch $id -o $T/w.png' '$T/detach.log'"
gate 2
wait_until 60 job_is "$id" done 1
start_client wint watch "$id" -o "$T/w.png" --server "$URL"
wait_until 60 logged wint 'pass 1/4'
kill -INT "$CPID"
client_rc
check watch_int_detaches "exit $CRC: $(cat "$T/wint.log")" bash -c \
    "[ $CRC = 130 ] && grep -q 'job $id goes on' '$T/wint.log' && grep -q 'rayd-client watch $id -o $T/w.png' '$T/wint.log'"
check watch_int_job_runs "state $(jfield "$T/body" state)" job_state_is "$id" running
check watch_int_keeps_pass "$(cat "$T/wint.log")" cmp -s "$T/w.png" "$T/ref1.png"
start_client watch watch "$id" -o "$T/w.png" --server "$URL"
wait_until 60 logged watch 'pass 1/4'
gate open
client_rc
code=$(req GET "/v1/jobs/$id/image.png")
check watch_resumes_to_end "exit $CRC: $(cat "$T/watch.log")" bash -c \
    "[ $CRC = 0 ] && [ $code = 200 ] && cmp -s '$T/body' '$T/w.png' && grep -q 'pass 4/4' '$T/watch.log'"
# a job that ended is written at once; an unknown id is the server's 404, said
"$CLIENT" watch "$id" -o "$T/w2.png" --server "$URL" -q 2>"$T/w2.log"
rc=$?
check watch_ended_job "exit $rc: $(cat "$T/w2.log")" bash -c "[ $rc = 0 ] && cmp -s '$T/body' '$T/w2.png'"
"$CLIENT" watch 0123456789abcdef0123456789abcdef -o "$T/w3.png" --server "$URL" 2>"$T/w3.log"
rc=$?
check watch_unknown_job "exit $rc: $(cat "$T/w3.log")" bash -c \
    "[ $rc = 1 ] && [ ! -e '$T/w3.png' ] && grep -q 'HTTP 404 job_unknown' '$T/w3.log'"

# a plain (not progressive) job: its final image
code=$(post_json /v1/jobs "$T/p2.json")
pid=$(jfield "$T/body" id)
"$CLIENT" watch "$pid" -o "$T/plain.png" --server "$URL" 2>"$T/plain.log"
rc=$?
check watch_plain_job "exit $rc: $(cat "$T/plain.log")" bash -c \
    "[ $rc = 0 ] && cmp -s '$T/plain.png' '$T/ref2.png' && grep -q 'job $pid succeeded; wrote' '$T/plain.log'"

# --- usage errors: nothing sent -------------------------------------------------------------------
for c in "bad_id:watch nothex -o $T/u.png:is no job id" \
    "stdout:render --progressive $T/p8.json -o -:give a file" \
    "tile:render --progressive $T/p8.json -o $T/u.png --tile 64:are for tiles" \
    "step_alone:render $T/p8.json -o $T/u.png --pass-step 2:go with render --progressive" \
    "step_not_whole:render --progressive $T/p8.json -o $T/u.png --pass-step 1.5:--pass-step needs a whole number" \
    "budget_exponent:render --progressive $T/p8.json -o $T/u.png --time-budget 1e3:--time-budget needs a number" \
    "budget_over_rayds:render --progressive $T/p8.json -o $T/u.png --time-budget 86401:--time-budget needs a number above 0 and at most 86400" \
    "budget_zero:render --progressive $T/p8.json -o $T/u.png --time-budget 0.0:--time-budget needs a number above 0" \
    "noise_over:render --progressive $T/p8.json -o $T/u.png --noise-target 1.5:--noise-target needs a number above 0 and at most 1 (digits" \
    "detach_job:job $T/p8.json -o $T/u.png --detach:job --detach leaves a frame range running"; do
    name=${c%%:*} c=${c#*:}
    # shellcheck disable=SC2086
    "$CLIENT" ${c%%:*} --server "$URL" >/dev/null 2>"$T/usage.log"
    rc=$?
    check "usage_$name" "exit $rc: $(cat "$T/usage.log")" bash -c "[ $rc = 2 ] && grep -q -- '${c#*:}' '$T/usage.log'"
done

# --- --pass-step goes to the server: passes of 3, 6, 8 samples ------------------------------------
"$CLIENT" render --progressive "$T/p8.json" -o "$T/step.png" --pass-step 3 --server "$URL" 2>"$T/step.log"
rc=$?
# (the job's record says the plan: on a busy machine the job can end before the client reads its
# first event, and then only the final image is fetched, with no pass line)
steps=$(curl -s "$URL/v1/jobs?limit=1" | python3 -c 'import json,sys; p=json.load(sys.stdin)["jobs"][0]["passes"]; print(p["done"], p["total"], p["samples"])')
check pass_step_passed "exit $rc, the job's passes $steps: $(cat "$T/step.log")" bash -c \
    "[ $rc = 0 ] && [ '$steps' = '3 3 8' ] && ! grep -q 'pass [0-9]/[^3]' '$T/step.log'"
stop_rayd

# --- a limit the server's operator raised is the server's to say, not the client's --------------
printf '{"render": {"samples": 2000, "width": 8, "height": 8}}' >"$T/s2k.json"
start_rayd --threads 1 --max-samples 4096
"$CLIENT" render "$T/s2k.json" -o "$T/s2k.png" --server "$URL" -q 2>"$T/s2k.log"
check client_takes_raised_samples "exit $?: $(cat "$T/s2k.log")" [ -s "$T/s2k.png" ]
stop_rayd
start_rayd --threads 1
"$CLIENT" render "$T/s2k.json" -o "$T/s2k2.png" --server "$URL" -q --retries 0 2>"$T/s2k.log"
rc=$?
check client_says_servers_limit "exit $rc: $(cat "$T/s2k.log")" bash -c \
    "[ $rc = 1 ] && grep -q -- \"the server's --max-samples\" '$T/s2k.log' && [ ! -e '$T/s2k2.png' ]"
stop_rayd

# --- a fake server: dropped and closed streams, hostile answers ---------------------------------
cat >"$T/fake.py" <<'PY'
import http.server, json, os, socketserver, struct, sys, time, zlib

LOG = sys.argv[1]
EVIL = "\x1b]0;pwned\x07\x1b[2J\r\x9b1m"
ID = "0123456789abcdef0123456789abcdef"
count = {"events": 0, "polls": 0}

def png(w, h, shade):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    row = b"\x00" + bytes([shade]) * (w * 3)
    data = zlib.compress(row * h)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", data) + chunk(b"IEND", b""))

def mode():
    return open(LOG + ".mode").read().strip() if os.path.exists(LOG + ".mode") else ""

def ev(name, data):
    return "event: %s\ndata: %s\n\n" % (name, json.dumps(data))

def pass_ev(k, **kw):
    d = {"pass": k, "passes": 4, "samples": 1 << (k - 1), "time_s": 0.1 * k, "noise": 0.1, "progress": 0.5}
    d.update(kw)
    return ev("pass", d)

class H(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.0"
    def log_message(self, *a):
        pass
    def send(self, status, ctype, body):
        self.send_response(status)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)
    def events(self):
        count["events"] += 1
        n, m = count["events"], mode()
        body = "retry: 100\n\n"
        if m == "drop":  # each connection gets one pass further, the third ends
            body += "".join(pass_ev(k) for k in range(1, min(n, 4) + 1))
            if n >= 3:
                body += "".join(pass_ev(k) for k in range(n + 1, 5)) + ev("done", {"state": "succeeded"})
        elif m == "absurd":
            body += (pass_ev(99) + pass_ev(1, samples=-5) + pass_ev(2, passes=2147483647)
                     + pass_ev(1, samples=1e300) + pass_ev(1, time_s=-1) + pass_ev(4, samples=4)
                     + ev("done", {"state": "succeeded"}))
        elif m == "failed":
            body += pass_ev(1) + ev("done", {"state": "failed", "error": "msg" + EVIL})
        elif m == "wrongsize":
            body += pass_ev(1)
        self.send_response(200)
        self.send_header("Content-Type", "text/event-stream")
        self.end_headers()
        self.wfile.write(body.encode())
        self.wfile.flush()
        if m == "wrongsize":  # open until the client leaves
            for _ in range(300):
                time.sleep(0.1)
                try:
                    self.wfile.write(b": keep-alive\n\n")
                    self.wfile.flush()
                except OSError:
                    return
    def job(self):
        m = mode()
        done = 0
        if m == "closed":
            count["polls"] += 1
            done = min(count["polls"] - 1, 4) if count["polls"] > 1 else 0
        state = "succeeded" if m == "closed" and count["polls"] > 5 else "running"
        size = 1024 if m == "region" else 64
        j = {"id": ID, "state": state, "region": {"x": 0, "y": 0, "w": size, "h": size},
             "passes": {"done": done, "total": 4, "samples": (1 << (done - 1)) if done else 0,
                        "samples_target": 8, "time_s": 0.1 * done}}
        self.send(200, "application/json", json.dumps(j).encode())
    def do_GET(self):
        open(LOG, "a").write("GET %s\n" % self.path)
        p = self.path
        if p.endswith("/events"):
            self.events()
        elif p == "/v1/jobs/" + ID:
            self.job()
        elif "/image.png" in p:
            k = int(p.split("pass=")[1]) if "pass=" in p else 5
            size = 1024 if mode() == "wrongsize" else 64
            self.send(200, "image/png", png(size, size, 40 * k))
        else:
            self.send(404, "application/json", b'{"error":{"status":404,"code":"not_found","message":"no"}}')
    def do_POST(self):
        self.rfile.read(int(self.headers.get("Content-Length", "0")))
        open(LOG, "a").write("POST %s\n" % self.path)
        count["events"] = count["polls"] = 0
        self.send(202, "application/json", json.dumps({"id": ID, "state": "queued"}).encode())
    def do_DELETE(self):
        open(LOG, "a").write("DELETE %s\n" % self.path)
        self.send(200, "application/json", json.dumps({"id": ID, "state": "canceled"}).encode())

class S(socketserver.ThreadingMixIn, http.server.HTTPServer):
    daemon_threads = True

s = S(("127.0.0.1", 0), H)
open(LOG + ".port.tmp", "w").write(str(s.server_address[1]))
os.rename(LOG + ".port.tmp", LOG + ".port")
s.serve_forever()
PY
python3 "$T/fake.py" "$T/fake.log" &
FAKE_PID=$!
PIDS+=("$FAKE_PID")
wait_until 30 test -s "$T/fake.log.port"
FAKE="http://127.0.0.1:$(cat "$T/fake.log.port")"
scene "$T/s64.json" 64 64 8 spheres
# fake_png K FILE: the fake server's image of pass K (5: the final one)
fake_png() { curl -s -o "$2" "$FAKE/v1/jobs/0123456789abcdef0123456789abcdef/image.png?pass=$1"; }
fake_png 5 "$T/fake-final.png"
# fake MODE NAME: render --progressive against the fake in MODE; status in FRC
fake() {
    echo "$1" >"$T/fake.log.mode"
    : >"$T/fake.log"
    "$CLIENT" render --progressive "$T/s64.json" -o "$T/$2.png" --server "$FAKE" >/dev/null 2>"$T/$2.log"
    FRC=$?
}
shows() { head -c 600 "$1" | cat -v; }
clean() { # no control byte but newlines, no C1, the server's ESC shown as \x1b
    ! LC_ALL=C grep -qP '[\x00-\x09\x0b-\x1f\x7f]|\xc2[\x80-\x9f]' "$1" && grep -qF '\x1b' "$1"
}

fake drop drop
check stream_dropped_reopened "exit $FRC, $(grep -c events "$T/fake.log") streams: $(shows "$T/drop.log")" bash -c \
    "[ $FRC = 0 ] && [ \$(grep -c '/events' '$T/fake.log') = 3 ] && cmp -s '$T/drop.png' '$T/fake-final.png' && \
     grep -q 'pass 1/4' '$T/drop.log' && grep -q 'pass 2/4' '$T/drop.log' && grep -q 'pass 4/4' '$T/drop.log' && \
     ! grep -q polling '$T/drop.log'"
fake closed closed
check stream_closed_polls "exit $FRC: $(shows "$T/closed.log")" bash -c \
    "[ $FRC = 0 ] && grep -q 'event stream failed (the server ended the stream): polling' '$T/closed.log' && \
     [ \$(grep -c '/events' '$T/fake.log') = 3 ] && grep -q 'pass 4/4' '$T/closed.log' && cmp -s '$T/closed.png' '$T/fake-final.png'"
fake wrongsize wrongsize
check hostile_wrong_size_refused "exit $FRC: $(shows "$T/wrongsize.log")" bash -c \
    "[ $FRC = 1 ] && [ ! -e '$T/wrongsize.png' ] && grep -q 'is 1024x1024, not the 64x64 asked for' '$T/wrongsize.log' && \
     grep -q '^DELETE /v1/jobs/0123456789abcdef0123456789abcdef' '$T/fake.log' && ! ls '$T' | grep -q 'wrongsize.png.*part'"
fake region region
check hostile_region_refused "exit $FRC: $(shows "$T/region.log")" bash -c \
    "[ $FRC = 1 ] && [ ! -e '$T/region.png' ] && grep -q 'its region is not the 64x64 image asked for' '$T/region.log' && \
     grep -q '^DELETE' '$T/fake.log' && ! grep -q '/events' '$T/fake.log'"
fake absurd absurd
check hostile_absurd_figures_ignored "exit $FRC: $(shows "$T/absurd.log")" bash -c \
    "[ $FRC = 0 ] && [ \$(grep -c 'pass figures make no sense' '$T/absurd.log') = 1 ] && ! grep -q 'pass=' '$T/fake.log' && \
     ! grep -Eq 'pass 99|2147483647|-5 |e\+?300' '$T/absurd.log' && cmp -s '$T/absurd.png' '$T/fake-final.png'"
fake failed failed
check hostile_failed_escaped "exit $FRC: $(shows "$T/failed.log")" bash -c \
    "[ $FRC = 1 ] && grep -q 'job 0123456789abcdef0123456789abcdef failed: msg' '$T/failed.log' && \
     grep -q 'failed.png holds pass 1 of 4 (1 samples)' '$T/failed.log'"
check hostile_failed_clean "$(shows "$T/failed.log")" clean "$T/failed.log"

# under SANITIZE=1 a report (overflow, leak, UB) in the client fails the script
if grep -lE 'ERROR: (Address|Leak)Sanitizer|runtime error:' "$T"/*.log >"$T/san" 2>/dev/null; then
    fail sanitizer_report "in $(tr '\n' ' ' <"$T/san")"
fi
kill "$FAKE_PID" 2>/dev/null
wait "$FAKE_PID" 2>/dev/null
true
