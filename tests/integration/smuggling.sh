#!/usr/bin/env bash
# smuggling.sh -- strict HTTP framing (RFC 9112), tried with raw sockets the
# way a request smuggler would: each case sends one request whose framing
# is ambiguous, with a second request hidden where its body would be -- a
# DELETE of a queued job.  The case passes when rayd answers what it must
# (400, 417, 501, ... and closes) AND exactly one request ran: the job is
# still queued and rayd_http_requests_total moved by one.  The test gate
# holds the jobs (--test-gate 0), so nothing renders and nothing depends on
# timing.  Then the other framing cases: one 400 for a missing Host, an
# absolute-form target served, Expect other than 100-continue 417, a NUL or
# an encoded / in the path 400, HEAD of a scene's image answered without a
# render.
source "$(dirname "$0")/lib/common.sh"

scene "$T/s.json" 8 8 1 spheres
start_rayd --test-gate 0 --timeout 3

python3 - "$PORT" "$T/s.json" <<'PY'
import json, re, socket, sys, time, urllib.request
port, scene_file = int(sys.argv[1]), sys.argv[2]
BASE = "http://127.0.0.1:%d" % port
scene = open(scene_file, "rb").read()
nfail = 0

def result(name, why):
    global nfail
    if why:
        nfail += 1
        print("FAIL smuggle-%s: %s" % (name, why))
    else:
        print("PASS smuggle-%s" % name)

def exchange(data, timeout=8):
    """data on a fresh connection; everything read until rayd closes it
    (or timeout: a connection rayd keeps open)."""
    s = socket.create_connection(("127.0.0.1", port), timeout=timeout)
    got = b""
    try:
        s.sendall(data)
        while True:
            d = s.recv(65536)
            if not d:
                break
            got += d
    except (socket.timeout, ConnectionResetError, BrokenPipeError):
        pass
    s.close()
    return got

def statuses(b):
    return [int(m) for m in re.findall(rb"HTTP/1\.1 (\d{3}) ", b)]

READINGS = [0]

def requests_total():
    """The sum of rayd_http_requests_total, settled: read until two readings
    in a row differ by one (the first reading counting itself), so no
    request is still on its way to the counter.  Returns (total, readings
    made so far): a reading is counted once it has been answered."""
    def read():
        READINGS[0] += 1
        text = urllib.request.urlopen(BASE + "/metrics", timeout=30).read().decode()
        return sum(float(l.split()[-1]) for l in text.splitlines()
                   if l.startswith("rayd_http_requests_total{"))
    a = read()
    for _ in range(100):
        time.sleep(0.05)
        b = read()
        if b - a == 1:
            break
        a = b
    return b, READINGS[0]

def new_job():
    req = urllib.request.Request(BASE + "/v1/jobs", data=scene,
                                 headers={"Content-Type": "application/json"})
    return json.loads(urllib.request.urlopen(req, timeout=30).read())["id"]

def job_state(j):
    try:
        return json.loads(urllib.request.urlopen(BASE + "/v1/jobs/" + j, timeout=30).read())["state"]
    except Exception as e:
        return "error %s" % e

def ran(before):
    """Requests rayd ran since before (a requests_total()), readings aside."""
    total, readings = requests_total()
    return int(total - before[0] - (readings - before[1]))

def smuggle(name, head, want, body=None, close=True, twice=False):
    """head: the first request's header lines (LEN is the smuggled request's
    length); its body: the smuggled DELETE (or body, with JOB in it).
    twice: libmicrohttpd 0.9.75 refuses it by itself, and writes the status
    line and headers of its 400 twice (docs/security.md)."""
    job = new_job()
    hidden = ("DELETE /v1/jobs/%s HTTP/1.1\r\nHost: x\r\n\r\n" % job).encode()
    if body is not None:
        hidden = body.replace(b"JOB", job.encode()).replace(b"HLEN", b"%x" % len(hidden)) \
            .replace(b"HIDDEN", hidden)
    head = head.replace("LEN", str(len(hidden)))
    before = requests_total()
    got = exchange(head.encode("latin-1") + hidden)
    st = statuses(got)
    n = ran(before)
    state = job_state(job)
    why = None
    if not st or st[0] != want or len(st) != 1 and not (twice and st == [want, want]):
        why = "answers %s, want [%d]: %r" % (st, want, got[:150])
    elif state != "queued":
        why = "the hidden DELETE ran: job %s" % state
    elif n != 1:
        why = "%d requests ran, want 1" % n
    elif close and not got.endswith(b"}\n") and b"Connection: close" not in got:
        why = "the connection was not closed: %r" % got[:150]
    result(name, why)

POST = "POST /v1/test/gate?tiles=0 HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
# whitespace before the colon: libmicrohttpd kept "Content-Length " as an
# unknown header, so the body ran as the next request (RFC 9112 5.1: 400)
smuggle("cl-space-before-colon", POST + "Content-Length : LEN\r\n\r\n", 400)
smuggle("cl-tab-before-colon", POST + "Content-Length\t: LEN\r\n\r\n", 400)
smuggle("te-space-before-colon", POST + "Transfer-Encoding : chunked\r\n\r\n", 400,
        b"HLEN\r\nHIDDEN\r\n0\r\n\r\n")
smuggle("te-tab-before-colon", POST + "Transfer-Encoding\t: chunked\r\n\r\n", 400)
# obsolete line folding (RFC 9112 5.2: 400): libmicrohttpd glued the folded
# line to the previous header's name
smuggle("te-obs-fold", POST + "Transfer-Encoding:\r\n chunked\r\n\r\n", 400,
        b"HLEN\r\nHIDDEN\r\n0\r\n\r\n")
smuggle("cl-obs-fold", POST + "Content-Length:\r\n LEN\r\n\r\n", 400)
smuggle("cl-folded-after", POST + "Content-Length: LEN\r\n x\r\n\r\n", 400)
smuggle("fold-tab", POST + "X-A: b\r\n\tContent-Length: LEN\r\n\r\n", 400)
# CL.TE and TE.CL: both headers, in either order
smuggle("cl-te", POST + "Content-Length: LEN\r\nTransfer-Encoding: chunked\r\n\r\n", 400)
smuggle("te-cl", POST + "Transfer-Encoding: chunked\r\nContent-Length: 3\r\n\r\n", 400,
        b"HLEN\r\nHIDDEN\r\n0\r\n\r\n")
smuggle("cl-cl-differ", POST + "Content-Length: 0\r\nContent-Length: LEN\r\n\r\n", 400)
# TE.TE: a coding libmicrohttpd does not decode, or two of them
smuggle("te-xchunked", POST + "Transfer-Encoding: xchunked\r\n\r\n", 400)
smuggle("te-chunked-identity", POST + "Transfer-Encoding: chunked, identity\r\n\r\n", 400)
smuggle("te-identity-chunked", POST + "Transfer-Encoding: identity, chunked\r\n\r\n", 501)
smuggle("te-te", POST + "Transfer-Encoding: chunked\r\nTransfer-encoding: cow\r\n\r\n", 400,
        b"HLEN\r\nHIDDEN\r\n0\r\n\r\n")
smuggle("te-trailing-space", POST + "Transfer-Encoding: chunked \r\n\r\n", 400)
smuggle("te-vertical-tab", POST + "Transfer-Encoding:\x0bchunked\r\n\r\n", 400)
smuggle("te-bare-cr", POST + "X-A: b\rTransfer-Encoding: chunked\r\n\r\n", 400,
        b"HLEN\r\nHIDDEN\r\n0\r\n\r\n")
smuggle("name-with-slash", POST + "Content/Length: LEN\r\n\r\n", 400)
# bare LF line ends: a proxy may read one line where rayd reads two
smuggle("bare-lf", POST.replace("\r\n", "\n") + "Content-Length: 0\n\n", 400)
smuggle("bare-lf-one-line", POST + "X-A: b\nContent-Length: 0\r\n\r\n", 400)
# Content-Length libmicrohttpd refuses itself (its 400 page)
smuggle("cl-plus", POST + "Content-Length: +LEN\r\n\r\n", 400, twice=True)
smuggle("cl-list", POST + "Content-Length: LEN, LEN\r\n\r\n", 400, twice=True)
# a chunk size with junk: refused, and the rest never read as a request
smuggle("chunk-size-junk", POST + "Transfer-Encoding: chunked\r\n\r\n", 400,
        b"5x\r\nhello\r\n0\r\n\r\nHIDDEN")
smuggle("chunk-size-overflow", POST + "Transfer-Encoding: chunked\r\n\r\n", 413,
        b"1ffffffffffffffff\r\nHIDDEN\r\n0\r\n\r\n")
# repeated Content-Type or Content-Encoding: rayd read the first, a proxy
# joining them reads "identity, gzip" (400, like a repeated Host)
smuggle("ct-twice", POST + "Content-Type: text/plain\r\nContent-Length: LEN\r\n\r\n", 400)
smuggle("ce-twice", POST + "Content-Encoding: identity\r\nContent-Encoding: gzip\r\n"
        "Content-Length: LEN\r\n\r\n", 400)
# Expect other than 100-continue: 417 before the body, which is never read
smuggle("expect-unknown", POST + "Expect: foo\r\nContent-Length: LEN\r\n\r\n", 417)

# a missing Host: one 400 (libmicrohttpd 0.9.75 wrote its own twice)
got = exchange(b"GET /healthz HTTP/1.1\r\n\r\n")
result("no-host-one-400", None if statuses(got) == [400] else "answers %s: %r" % (statuses(got), got[:200]))
got = exchange(b"GET /healthz HTTP/1.1\r\nHost: a\r\nHost: b\r\nConnection: close\r\n\r\n")
result("two-hosts-400", None if statuses(got) == [400] else "answers %s" % statuses(got))
# HTTP/1.0 needs no Host
got = exchange(b"GET /healthz HTTP/1.0\r\n\r\n")
result("http10-no-host-200", None if statuses(got) == [] and got.startswith(b"HTTP/1.0 200")
       or statuses(got) == [200] else "answer %r" % got[:80])
# absolute-form targets are accepted (RFC 9112 3.2.2)
for name, target in [("absolute-form", "http://x/healthz"),
                     ("absolute-form-https", "HTTPS://rayd.example:8080/healthz")]:
    got = exchange(("GET %s HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n" % target).encode())
    result(name, None if statuses(got) == [200] and got.endswith(b'"ok"}\n') or statuses(got) == [200]
           else "answers %s" % statuses(got))
got = exchange(b"GET http:///healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
result("absolute-form-no-host-400", None if statuses(got) == [400] else "answers %s" % statuses(got))
got = exchange(b"GET /healthz HTTP/1.1\r\nHost: x\r\nExpect: foo\r\nConnection: close\r\n\r\n")
result("expect-foo-417", None if statuses(got) == [417] else "answers %s" % statuses(got))
got = exchange(b"GET /healthz HTTP/1.1\r\nHost: x\r\nExpect: 100-Continue\r\nConnection: close\r\n\r\n")
result("expect-100-continue-200", None if statuses(got) in ([200], [100, 200])
       else "answers %s" % statuses(got))
for name, target in [("nul-in-path", "/app.js%00.png"), ("encoded-slash", "/v1%2fjobs"),
                     ("encoded-slash-upper", "/v1/jobs%2F0123"), ("encoded-control", "/app.js%0a"),
                     ("space-in-target", "/health z")]:
    got = exchange(("GET %s HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n" % target).encode())
    body = got.partition(b"\r\n\r\n")[2]
    result(name + "-400", None if statuses(got) == [400] and b"bad_request" in body
           else "answers %s: %r" % (statuses(got), body[:100]))
# a query of parameters by the hundred: 400 at once, not a hang (libmicrohttpd's pool once ran
# out on 600 of them and left no room for any answer until --timeout)
for n in (600, 5000):
    got = exchange(("GET /healthz?%s HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"
                    % "&".join(["a"] * n)).encode())
    body = got.partition(b"\r\n\r\n")[2]
    result("query-%d-params-400" % n, None if statuses(got) == [400] and
           b"more than 256 parameters" in body
           else "answers %s (none: no answer within exchange's timeout): %r" % (statuses(got), body[:100]))
got = exchange(("GET /healthz?%s HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"
                % "&".join(["a"] * 200)).encode())
result("query-200-params-ok", None if statuses(got) == [200] else "answers %s" % statuses(got))
# HEAD of an event stream: its headers alone, no chunk after them that a pipelining client would
# read as the next answer (rayd may close the connection after them: no length to frame by)
job = new_job()
got = exchange(("HEAD /v1/jobs/%s/events HTTP/1.1\r\nHost: x\r\n\r\n"
                "GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n" % job).encode())
first, _, rest = got.partition(b"\r\n\r\n")
result("head-events-headers-only", None if statuses(got) in ([200], [200, 200]) and
       b"text/event-stream" in first and (rest == b"" or rest.startswith(b"HTTP/1.1 200"))
       else "answers %s: %r" % (statuses(got), got[:300]))
# a %2F in the query is no path separator: still served
got = exchange(b"GET /healthz?x=a%2Fb HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
result("encoded-slash-in-query-ok", None if statuses(got) == [200] else "answers %s" % statuses(got))

# pipelined requests with sound framing still both run
before = requests_total()
got = exchange(b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n"
               b"GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
result("pipeline-two-200", None if statuses(got) == [200, 200] and ran(before) == 2
       else "answers %s" % statuses(got))
before = requests_total()
got = exchange(b"POST /v1/test/gate?tiles=0 HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n"
               b"0\r\n\r\nGET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
result("chunked-then-pipelined", None if statuses(got) == [200, 200] and ran(before) == 2
       else "answers %s" % statuses(got))

# HEAD of a scene's image: the headers, no render (the gate lets no tile
# start, so a render would hold the answer; and the gate counts none queued)
req = urllib.request.Request(BASE + "/v1/scenes", data=scene,
                             headers={"Content-Type": "application/json"})
sid = json.loads(urllib.request.urlopen(req, timeout=30).read())["id"]
def gate_now():
    return json.loads(urllib.request.urlopen(BASE + "/v1/test/gate", timeout=30).read())
gate0 = gate_now()  # the jobs above are still held there
got = exchange(("HEAD /v1/scenes/%s/image.png HTTP/1.1\r\nHost: x\r\n\r\n" % sid).encode(), timeout=10)
gate = gate_now()
head, _, body = got.partition(b"\r\n\r\n")
why = None
if statuses(got) != [200] or b"Content-Type: image/png" not in head or b"ETag: " not in head:
    why = "answer %r" % got[:300]
elif body:
    why = "a body after HEAD: %r" % body[:40]
elif gate != gate0:
    why = "a render was queued: gate %s, before %s" % (gate, gate0)
result("head-scene-image-no-render", why)
got = exchange(("HEAD /v1/scenes/%s/image.png HTTP/1.1\r\nHost: x\r\n\r\n" % ("0" * 64)).encode())
result("head-scene-image-unknown-404", None if statuses(got) == [404] else "answers %s" % statuses(got))
sys.exit(0)
PY

check smuggling_healthz_after "status" [ "$(req GET /healthz)" = 200 ]
check smuggling_no_500 "a 500 was counted" bash -c "! curl -s '$URL/metrics' | grep -q 'code=\"500\"'"
stop_rayd TERM
check smuggling_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
