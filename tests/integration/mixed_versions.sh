#!/usr/bin/env bash
# mixed_versions.sh -- one frame is never stitched from two rayd versions.
#
# Two versions may draw the same scene differently, and a frame stitched
# from both would equal neither's render.  Every image answer says which
# version drew it (X-Rayd-Version) and rayd-client refuses a frame whose
# pieces disagree.  A node of another version is simulated by a small
# Python proxy in front of a real node that rewrites that header (as an
# upgraded node would answer), or rewrites it on every second image (as a
# balancer's cache holding an older node's tiles among new ones would): the
# frame meets both versions whichever node is faster.  Also: the immutable tile's strong ETag names its bytes, so it
# changes with the deflate level (and the version) that made them; and
# rayd-client health shows each node's version and fails on a mix.
source "$(dirname "$0")/lib/common.sh"

CLIENT=$RAYD_BUILD/rayd-client
[ -x "$CLIENT" ] || { echo "FAIL setup: $CLIENT missing"; exit 1; }
version=$("$RAYD" --version | awk '{print $2}')

start_node 1 --threads 1
start_node 2 --threads 1 --png-level 1
A=${NODE_URL[1]} B=${NODE_URL[2]}

# --- a proxy that answers as another version ----------------------------------------
cat >"$T/other.py" <<'PY'
import http.client, itertools, json, sys, threading, urllib.parse
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
up = urllib.parse.urlsplit(sys.argv[1])
alternate = len(sys.argv) > 3 and sys.argv[3] == "alternate"
images, lock = itertools.count(), threading.Lock()
def other(version):
    # "always": every answer is 9.9.9's; "alternate": every second piece of
    # an image, an answer that says its version (a balancer whose cache
    # holds an older node's tiles among new ones)
    if not alternate:
        return True
    if not version:
        return False
    with lock:
        return next(images) % 2 == 1
class H(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"
    def log_message(self, *a): pass
    def relay(self):
        n = int(self.headers.get("Content-Length") or 0)
        body = self.rfile.read(n) if n else None
        c = http.client.HTTPConnection(up.hostname, up.port, timeout=60)
        hdrs = {k: v for k, v in self.headers.items() if k.lower() in ("content-type", "authorization")}
        c.request(self.command, self.path, body=body, headers=hdrs)
        r = c.getresponse()
        data = r.read()
        if self.path == "/healthz" and not alternate:  # its body says the version too
            j = json.loads(data)
            j["version"] = "9.9.9"
            data = json.dumps(j).encode()
        swap = other(r.getheader("X-Rayd-Version"))
        self.send_response(r.status)
        for k, v in r.getheaders():
            if k.lower() not in ("content-length", "connection", "date") and \
                    not (swap and k.lower() == "x-rayd-version"):
                self.send_header(k, v)
        if swap:
            self.send_header("X-Rayd-Version", "9.9.9")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)
    do_GET = do_POST = relay
s = ThreadingHTTPServer(("127.0.0.1", 0), H)
open(sys.argv[2], "w").write("http://127.0.0.1:%d\n" % s.server_address[1])
s.serve_forever()
PY
python3 "$T/other.py" "$B" "$T/other.url.tmp" >"$T/other.log" 2>&1 &
PIDS+=($!)
wait_until 30 test -s "$T/other.url.tmp"
O=$(cat "$T/other.url.tmp")
# M: before A, every second image as 9.9.9's, so any frame of two pieces or
# more meets both versions, however the client spreads its pieces
python3 "$T/other.py" "$A" "$T/mix.url.tmp" alternate >"$T/mix.log" 2>&1 &
PIDS+=($!)
wait_until 30 test -s "$T/mix.url.tmp"
M=$(cat "$T/mix.url.tmp")

# --- the header and the ETag ---------------------------------------------------------
scene "$T/s.json" 160 96 1 spheres
tile_headers() { # tile_headers URL FILE: POST the scene, GET one tile's headers into FILE
    local id
    id=$(curl -s -m 30 -H 'Content-Type: application/json' --data-binary @"$T/s.json" "$1/v1/scenes" |
        python3 -c 'import json,sys; print(json.load(sys.stdin)["id"])')
    curl -s -m 30 -D "$2" -o /dev/null "$1/v1/scenes/$id/image.png?x=0&y=0&w=32&h=32"
}
tile_headers "$A" "$T/a.h"
tile_headers "$B" "$T/b.h"
hval() { grep -i "^$1:" "$2" | sed 's/^[^:]*: *//; s/\r$//'; }
check tile_says_version "X-Rayd-Version '$(hval X-Rayd-Version "$T/a.h")', rayd --version $version" \
    [ "$(hval X-Rayd-Version "$T/a.h")" = "$version" ]
check render_says_version "no X-Rayd-Version on POST /v1/render" bash -c \
    "curl -s -m 30 -D - -o /dev/null -H 'Content-Type: application/json' --data-binary @'$T/s.json' \
     '$A/v1/render?x=0&y=0&w=8&h=8' | grep -qi '^X-Rayd-Version: $version'"
check etag_names_bytes "the same ETag for the bytes of the default level and --png-level 1: $(hval ETag "$T/a.h")" \
    [ -n "$(hval ETag "$T/a.h")" -a "$(hval ETag "$T/a.h")" != "$(hval ETag "$T/b.h")" ]

# --- rayd-client health: the versions, and a mix named before any frame -----------------
"$CLIENT" health --server "$A" --server "$B" >"$T/h.out" 2>"$T/h.err"
RC=$?
check health_says_version "exit $RC: $(cat "$T/h.out" "$T/h.err")" bash -c \
    "[ $RC = 0 ] && [ \$(grep -c 'live (rayd $version), ready' '$T/h.out') = 2 ]"
"$CLIENT" health --server "$A" --server "$O" >"$T/hm.out" 2>"$T/hm.err"
RC=$?
check health_mixed_versions "exit $RC: $(cat "$T/hm.out" "$T/hm.err")" bash -c \
    "[ $RC = 1 ] && grep -q 'runs rayd $version and .* rayd 9.9.9: a frame needs one rayd version' '$T/hm.err'"

# --- rayd-client: one version per frame -------------------------------------------------
"$RENDER" "$T/s.json" -o "$T/ref.png" 2>/dev/null
timeout 120 "$CLIENT" render "$T/s.json" -o "$T/same.png" --tile 32 --server "$A" --server "$B" \
    2>"$T/same.err"
check same_version_frame "exit $?: $(tail -n 2 "$T/same.err")" cmp -s "$T/ref.png" "$T/same.png"

timeout 120 "$CLIENT" render "$T/s.json" -o "$T/mixed.png" --tile 32 --server "$M" \
    2>"$T/mixed.err"
RC=$?
check mixed_versions_exit_1 "exit $RC" [ "$RC" = 1 ]
check mixed_versions_said "stderr: $(grep -v '%)' "$T/mixed.err" | head -c 400)" \
    grep -q "^rayd-client: error: .* drew a tile with rayd .*, .* with rayd .*: one frame needs the same rayd version on every node" "$T/mixed.err"
check mixed_versions_both_named "stderr: $(grep error "$T/mixed.err" | head -c 400)" \
    bash -c "grep error '$T/mixed.err' | grep -q 'rayd 9.9.9' && grep error '$T/mixed.err' | grep -q 'rayd $version'"
check mixed_versions_no_file "an image was written" [ ! -e "$T/mixed.png" ]

scene "$T/p.json" 64 48 8 spheres
timeout 120 "$CLIENT" render "$T/p.json" -o "$T/mixed_s.png" --split-samples 4 --parallel 4 \
    --server "$M" 2>"$T/mixed_s.err"
RC=$?
check mixed_versions_samples "exit $RC: $(grep error "$T/mixed_s.err" | head -c 300)" \
    bash -c "[ $RC = 1 ] && grep -q 'one frame needs the same rayd version' '$T/mixed_s.err' && [ ! -e '$T/mixed_s.png' ]"
