#!/usr/bin/env bash
# client_untrusted.sh -- rayd-client treats the server as untrusted.
#
# A fake, hostile server (python3 http.server on a port it picks itself,
# stopped by PID) answers with terminal escapes in its version, error
# codes, messages and paths, absurd progress figures, and an image of
# another size than the scene's.  The client must print none of those
# bytes raw (they come out as \xNN), refuse the image (exit 1, no file
# written), and ignore the figures with a warning.  A scene whose own
# "file" names are absolute, contain "..", or lead out through a symbolic
# link is refused before any request (the fake server sees no POST).
# (On 3f5321f: raw ESC on the terminal, the 1024x1024 PNG written for a
# 64x64 job, "2147483647/1 tiles (-2147483648%)", /etc/passwd sent.)
source "$(dirname "$0")/lib/common.sh"
CLIENT=$RAYD_BUILD/rayd-client

cat >"$T/fake.py" <<'PY'
import http.server, json, os, re, socketserver, struct, sys, zlib

LOG = sys.argv[1]
EVIL = "\x1b]0;pwned\x07\x1b[2J\x1b[31mred\r\x9b1mC1\x7f"
ID = "0123456789abcdef0123456789abcdef"
FID = "fedcba9876543210fedcba9876543210"  # a frame-range job's

def png(w, h):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    z = zlib.compressobj(1)
    data = b"".join(z.compress(b"\x00" * (w * 3 + 1)) for _ in range(h)) + z.flush()
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", data) + chunk(b"IEND", b""))

def exr(w, h):
    def attr(name, typ, value):
        return name + b"\x00" + typ + b"\x00" + struct.pack("<i", len(value)) + value
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    return (b"\x76\x2f\x31\x01" + struct.pack("<I", 2) + attr(b"compression", b"compression", b"\x00")
            + attr(b"dataWindow", b"box2i", box) + attr(b"displayWindow", b"box2i", box) + b"\x00")

class H(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.0"
    def log_message(self, *a):
        pass
    def send(self, status, ctype, body, extra=()):
        self.send_response(status)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        for k, v in extra:
            self.send_header(k, v)
        self.end_headers()
        self.wfile.write(body)
    def error(self, status):
        e = {"error": {"status": status, "code": "bad" + EVIL, "message": "msg" + EVIL,
                       "path": "/objects/0" + EVIL}}
        self.send(status, "application/json", json.dumps(e).encode())
    def mode(self):  # which hostile answer, from the scene's width
        return open(LOG + ".mode").read().strip() if os.path.exists(LOG + ".mode") else ""
    def do_GET(self):
        open(LOG, "a").write("GET %s\n" % self.path)
        if self.path == "/healthz":
            self.send(200, "application/json", json.dumps({"status": "ok", "version": "9" + EVIL}).encode())
        elif self.path == "/readyz":
            self.send(200, "application/json", json.dumps({"status": "ready", "queued": 0, "capacity": 4,
                      "workers": 1, "busy": 0, "jobs": 0, "max_jobs": 4, "jobs_refused": "full" + EVIL}).encode())
        elif self.path == "/v1/jobs/" + FID:  # a frame-range job, its figures as mode says
            bad = self.mode() == "frames-bad"
            job = {"id": FID, "state": "failed", "error": {"message": "frame 1 failed"},
                   "region": {"x": 0, "y": 0, "w": 16, "h": 16},
                   "frames": {"first": 5 if bad else 0, "last": 3 if bad else 1, "total": 2,
                              "done": 1, "queued": 0, "running": 0, "failed": 1},
                   "eta_s": 1e300}
            self.send(200, "application/json", json.dumps(job).encode())
        elif self.path == "/v1/jobs/%s/events" % FID:
            self.send(200, "text/event-stream", b'event: done\ndata: {"state": "failed"}\n\n')
        elif self.path == "/v1/jobs/%s/frames/0.png" % FID:
            self.send(200, "image/png", png(16, 16))
        elif self.path.endswith("/events"):
            ev = ('event: progress\ndata: {"done": 2147483647, "total": 1}\n\n'
                  'event: progress\ndata: {"done": -5, "total": -2147483648}\n\n'
                  'event: progress\ndata: {"done": 1e300, "total": 1e300}\n\n'
                  'event: done\ndata: {"state": "succeeded"}\n\n')
            self.send(200, "text/event-stream", ev.encode())
        elif self.path.endswith("/image.png") and self.mode() == "error":
            self.error(409)
        elif self.path.endswith("/image.png"):
            self.send(200, "image/png", png(1024, 1024))
        elif self.path.endswith("/image.exr"):
            self.send(200, "image/x-exr", exr(1024, 1024))
        elif self.path.startswith("/metrics"):
            self.send(200, "text/plain", b"rayd_rays_total 1\n")
        else:
            self.error(404)
    def do_POST(self):
        n = int(self.headers.get("Content-Length", "0"))
        body = self.rfile.read(n)
        open(LOG, "a").write("POST %s\n" % self.path)
        if self.path.startswith("/v1/jobs"):
            self.send(202, "application/json", json.dumps({"id": ID, "state": "queued"}).encode())
        else:
            self.error(400)
    def do_DELETE(self):
        open(LOG, "a").write("DELETE %s\n" % self.path)
        self.error(404)

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

# clean FILE: no control byte (but the newline), no DEL, no C1 (raw or as
# UTF-8) and no byte that is no UTF-8 in FILE; the server's ESC shows as \x1b
clean() {
    python3 - "$1" <<'PY'
import re, sys
d = open(sys.argv[1], "rb").read()
bad = re.search(rb"[\x00-\x09\x0b-\x1f\x7f]|\xc2[\x80-\x9f]", d)
try:
    d.decode("utf-8")
except UnicodeDecodeError:
    bad = True
sys.exit(1 if bad or b"\\x1b" not in d else 0)
PY
}
shows() { python3 -c 'import sys; print(repr(open(sys.argv[1], "rb").read()[:400]))' "$1"; }
posts() { grep -c '^POST' "$T/fake.log"; }

# --- watch of a frame-range job: its frames and eta_s checked, not trusted ------------------
FID=fedcba9876543210fedcba9876543210
echo frames-bad >"$T/fake.log.mode"
"$CLIENT" watch "$FID" -o "$T/wf-%d.png" --server "$FAKE" >"$T/wf.out" 2>&1
rc=$?
check untrusted_watch_frames_refused "exit $rc: $(shows "$T/wf.out")" bash -c "[ $rc = 1 ] &&
    grep -q 'its frames {\"first\":5,\"last\":3' '$T/wf.out' && ! ls '$T' | grep -q '^wf-'"
echo frames-eta >"$T/fake.log.mode"
"$CLIENT" watch "$FID" -o "$T/wf-%d.png" --server "$FAKE" >"$T/wf.out" 2>&1
rc=$?
# an eta_s of 1e300 made "ETA -596523h-14m" (a float to int out of range); now unknown
check untrusted_watch_eta_ignored "exit $rc: $(shows "$T/wf.out")" bash -c "[ $rc = 1 ] &&
    [ -e '$T/wf-0.png' ] && grep -q 'frame 0 -> .*ETA' '$T/wf.out' && ! grep -q 'ETA -' '$T/wf.out'"
rm -f "$T/fake.log.mode"

# --- health: the version and the reason are escaped -------------------------------------
"$CLIENT" health --server "$FAKE" >"$T/health.out" 2>&1
check untrusted_health_escaped "$(shows "$T/health.out")" clean "$T/health.out"
check untrusted_health_says_version "$(shows "$T/health.out")" grep -q 'rayd 9\\x1b\]0;pwned\\x07' "$T/health.out"

# --- job: absurd progress ignored with a warning, a 1024x1024 PNG for a 64x64 job refused --
scene "$T/s64.json" 64 64 1 spheres
: >"$T/fake.log.mode"
"$CLIENT" job "$T/s64.json" -o "$T/job.png" --server "$FAKE" >"$T/job.out" 2>&1
rc=$?
check untrusted_wrong_png_refused "exit $rc: $(shows "$T/job.out")" \
    bash -c "[ $rc = 1 ] && [ ! -e '$T/job.png' ] && [ -z \"\$(find '$T' -name 'job.png*.part')\" ] && grep -q 'is 1024x1024, not the 64x64 asked for' '$T/job.out'"
check untrusted_progress_ignored "$(shows "$T/job.out")" bash -c \
    "grep -q 'warning: the server.s progress figures make no sense' '$T/job.out' && ! grep -Eq '2147483647/|-2147483648|/-|[0-9]{4,}%' '$T/job.out'"
check untrusted_progress_warned_once "$(shows "$T/job.out")" [ "$(grep -c 'progress figures' "$T/job.out")" = 1 ]

# --- job -o .exr: an EXR whose dataWindow is not the scene's is refused too -------------------
"$CLIENT" job "$T/s64.json" -o "$T/job.exr" --server "$FAKE" -q >"$T/exr.out" 2>&1
rc=$?
check untrusted_wrong_exr_refused "exit $rc: $(shows "$T/exr.out")" \
    bash -c "[ $rc = 1 ] && [ ! -e '$T/job.exr' ] && grep -q 'is 1024x1024, not the 64x64 asked for' '$T/exr.out'"

# --- job: an error's code, message and path are escaped ---------------------------------------
echo error >"$T/fake.log.mode"
"$CLIENT" job "$T/s64.json" -o "$T/err.png" --server "$FAKE" -q >"$T/err.out" 2>&1
rc=$?
check untrusted_job_error_escaped "exit $rc: $(shows "$T/err.out")" \
    bash -c "[ $rc = 1 ] && [ ! -e '$T/err.png' ] && grep -q 'HTTP 409 bad\\\\x1b' '$T/err.out'"
check untrusted_job_error_clean "$(shows "$T/err.out")" clean "$T/err.out"

# --- render: the scene's refusal is escaped --------------------------------------------------
"$CLIENT" render "$T/s64.json" -o "$T/r.png" --server "$FAKE" -q --retries 0 >"$T/render.out" 2>&1
rc=$?
check untrusted_render_error_clean "exit $rc: $(shows "$T/render.out")" \
    bash -c "[ $rc = 1 ] && [ ! -e '$T/r.png' ] && grep -q 'HTTP 400 bad' '$T/render.out'"
check untrusted_render_error_escaped "$(shows "$T/render.out")" clean "$T/render.out"

# --- a scene's own "file" names are confined before anything is sent ---------------------------
mkdir -p "$T/sc/sub"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >"$T/outside.obj"
cp "$T/outside.obj" "$T/sc/sub/ok.obj"
ln -s ../../outside.obj "$T/sc/sub/link.obj"
mesh() { # mesh NAME FILE: a scene in $T/sc whose one mesh is FILE
    printf '{"render": {"width": 16, "height": 16},
  "objects": [{"type": "sphere", "radius": 1},
              {"type": "mesh", "source": {"file": "%s", "format": "obj"}}]}\n' "$2" >"$T/sc/$1.json"
}
mesh abs /etc/passwd
mesh dotdot ../outside.obj
mesh dotdot_inner sub/../sub/ok.obj
mesh link sub/link.obj
mesh good sub/ok.obj
printf '{"render": {"width": 16, "height": 16, "environment": {"file": "../sky.hdr"}}}\n' >"$T/sc/env.json"
before=$(posts)
for c in abs:"is an absolute path" dotdot:"has a '..' component" dotdot_inner:"has a '..' component" \
    link:"leads out of the scene's folder" env:"has a '..' component"; do
    name=${c%%:*} why=${c#*:}
    at=/objects/1/source/file
    [ "$name" = env ] && at=/render/environment/file
    for cmd in job render; do
        "$CLIENT" "$cmd" "$T/sc/$name.json" -o "$T/sc/$name.png" --server "$FAKE" -q >"$T/sc/$name.out" 2>&1
        rc=$?
        check "untrusted_file_${name}_${cmd}_refused" "exit $rc: $(shows "$T/sc/$name.out")" \
            bash -c "[ $rc = 1 ] && [ ! -e '$T/sc/$name.png' ] && grep -qF \"$T/sc/$name.json: $at: \" '$T/sc/$name.out' && grep -qF \"$why\" '$T/sc/$name.out'"
    done
done
check untrusted_file_nothing_sent "POSTs: $(grep POST "$T/fake.log" | tail -n 3)" [ "$(posts)" = "$before" ]
# a name inside the scene's folder is still sent (the fake server then answers badly)
"$CLIENT" job "$T/sc/good.json" -o "$T/sc/good.png" --server "$FAKE" -q >"$T/sc/good.out" 2>&1
check untrusted_file_inside_sent "POSTs $(posts), $(shows "$T/sc/good.out")" [ "$(posts)" = $((before + 1)) ]

# under SANITIZE=1 a report (overflow, leak, UB) in the client fails the script
if grep -lE 'ERROR: (Address|Leak)Sanitizer|runtime error:' "$T"/*.out "$T"/sc/*.out >"$T/san" 2>/dev/null; then
    fail sanitizer_report "in $(tr '\n' ' ' <"$T/san")"
fi
kill "$FAKE_PID" 2>/dev/null
wait "$FAKE_PID" 2>/dev/null # killed: its status is no failure of the test
true
