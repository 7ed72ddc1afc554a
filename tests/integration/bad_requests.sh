#!/usr/bin/env bash
# bad_requests.sh -- the bad-HTTP-request corpus (tests/bad/requests/): every
# raw request in cases/*.http is sent on its own connection to a real rayd;
# the answer must have the status of manifest.tsv and, when rayd's own code
# answered, the API's JSON error body with that code (libmicrohttpd's own
# refusals -- code `-` -- are checked by status only); GET /healthz must
# answer 200 after each case; nothing may be answered 500.  Then a bad
# method's message: a non-token's bytes not echoed, a long token's cut.
source "$(dirname "$0")/lib/common.sh"

CORPUS="$RAYD_ROOT/tests/bad/requests"
printf 'corpus-T0ken\n' >"$T/token"
start_rayd --threads 2 --max-body 65536 --max-pixels 1000000 --max-url 4096 --timeout 2 \
    --token-file "$T/token"

python3 - "$PORT" "$CORPUS" <<'PY'
import json, os, socket, sys, time
port, corpus = int(sys.argv[1]), sys.argv[2]

def exchange(data, shut):
    """Sends data on a fresh connection, returns the raw answer (b'' if closed)."""
    s = socket.create_connection(("127.0.0.1", port), timeout=15)
    got = b""
    try:
        try:
            s.sendall(data)
        except (BrokenPipeError, ConnectionResetError):
            pass  # refused before the whole request was read: read the answer
        if shut:
            s.shutdown(socket.SHUT_WR)
        while True:
            try:
                d = s.recv(65536)
            except ConnectionResetError:
                break
            if not d:
                break
            got += d
    finally:
        s.close()
    return got

def parse(resp):
    head, _, body = resp.partition(b"\r\n\r\n")
    lines = head.split(b"\r\n")
    parts = lines[0].split(b" ", 2)
    status = int(parts[1]) if len(parts) > 1 and parts[1].isdigit() else None
    hdrs = {}
    for l in lines[1:]:
        k, _, v = l.partition(b":")
        hdrs.setdefault(k.strip().lower().decode("latin-1"), v.strip().decode("latin-1"))
    return status, hdrs, body

def healthy():
    r = exchange(b"GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n", False)
    return parse(r)[0] == 200 if r else False

n = 0
for line in open(os.path.join(corpus, "manifest.tsv")):
    if line.startswith("#") or not line.strip():
        continue
    name, want, code, shut, what = line.rstrip("\n").split("\t")
    n += 1
    data = open(os.path.join(corpus, "cases", name + ".http"), "rb").read()
    t0 = time.time()
    try:
        resp = exchange(data, shut == "shut")
    except Exception as e:
        print("FAIL bad-request-%s: %s: %r" % (name, what, e))
        continue
    ms = (time.time() - t0) * 1e3
    why = None
    if want == "close":
        if resp:
            why = "expected the connection closed without an answer, got %r" % resp[:60]
    else:
        status, hdrs, body = parse(resp) if resp else (None, {}, b"")
        if status != int(want):
            why = "status %s, want %s; got %r" % (status, want, resp[:120])
        elif code != "-":
            try:
                e = json.loads(body)["error"]
                if not (hdrs.get("content-type", "").startswith("application/json")
                        and e["status"] == int(want) and e["code"] == code
                        and isinstance(e["message"], str) and e["message"]
                        and set(e) <= {"status", "code", "message", "path", "line", "column",
                                       "parameter"}):
                    why = "error body %r, want code %s" % (body[:200], code)
                elif want == "503" and "retry-after" not in hdrs:
                    why = "503 without Retry-After"
                elif want == "401" and not hdrs.get("www-authenticate", "").startswith("Bearer"):
                    why = "401 without WWW-Authenticate: Bearer"
                elif want == "405" and "allow" not in hdrs:
                    why = "405 without Allow"
            except Exception as ex:
                why = "not the JSON error body (%s): %r" % (ex, body[:200])
    if why is None and not healthy():
        why = "GET /healthz failed after it"
    if why:
        print("FAIL bad-request-%s: %s: %s" % (name, what, why))
    else:
        print("PASS bad-request-%s (%s, %.0f ms)" % (name, want, ms))
print("cases %d" % n, file=sys.stderr)
PY

# a method's refusal echoes none of a non-token's bytes (400), and at most
# 40 bytes of a token (405): the message is the client's to show
python3 - "$PORT" <<'PY'
import json, socket, sys
def message(method):
    s = socket.create_connection(("127.0.0.1", int(sys.argv[1])), timeout=15)
    s.sendall(method + b" /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
    got = b""
    while True:
        d = s.recv(65536)
        if not d:
            break
        got += d
    s.close()
    return json.loads(got.partition(b"\r\n\r\n")[2])["error"]["message"]
m = message(b"G<script>T")
print("PASS method_not_echoed" if "script" not in m else "FAIL method_not_echoed: %r" % m)
m = message(b"A" * 300)
ok = "A" * 40 in m and "A" * 41 not in m
print("PASS method_echo_cut" if ok else "FAIL method_echo_cut: %r" % m[:200])
PY

count=$(grep -vc '^#' "$CORPUS/manifest.tsv")
check bad_requests_corpus_size "only $count cases" [ "$count" -ge 100 ]
check bad_requests_no_500 "a 500 was counted" bash -c "! curl -s -H 'Authorization: Bearer corpus-T0ken' '$URL/metrics' | grep -q 'code=\"500\"'"
check bad_requests_still_ready "readyz" [ "$(req GET /readyz)" = 200 ]
stop_rayd TERM
check bad_requests_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
