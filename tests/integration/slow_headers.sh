#!/usr/bin/env bash
# slow_headers.sh -- --header-seconds, the total deadline for a request's
# line and headers (slowloris).  --timeout is an idle timeout: a client that
# sends a header line every second is never idle, and enough of them held
# every --max-conns slot, so nobody else was answered.  Here 20 such
# connections fill --max-conns 20: each is closed about --header-seconds
# (2) after its accept, a /healthz that waited behind them is answered, each
# cut is one access line (408, note=header_timeout) and counted in
# rayd_rejections_total{reason="header_timeout"}; headers that take a
# second in all are served; a keep-alive connection may idle between
# requests past the deadline, but a next request that trickles is cut.
source "$(dirname "$0")/lib/common.sh"

# slowloris.py PORT N SECONDS READY: opens N connections, each sending a
# request line, a Host and then one header line a second, never ending the
# block; writes READY once all are open; prints for each the seconds from
# its connect to the server's close ("open" if still open after SECONDS).
cat >"$T/slowloris.py" <<'PY'
import socket, sys, time
port, n, secs, ready = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
conns = []
for i in range(n):
    t0 = time.time()  # before the connect: never less than the server's own count
    s = socket.create_connection(("127.0.0.1", port), timeout=10)
    s.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
    s.setblocking(False)
    conns.append([s, t0, None])
open(ready, "w").write("%d\n" % len(conns))
end, last = time.time() + secs, 0.0
while time.time() < end and any(c[2] is None for c in conns):
    for c in conns:
        if c[2] is not None:
            continue
        try:
            if c[0].recv(100) == b"":
                c[2] = time.time() - c[1]
                continue
        except BlockingIOError:
            pass
        except OSError:
            c[2] = time.time() - c[1]
            continue
        if time.time() - last >= 1:
            try:
                c[0].send(b"X-a: b\r\n")
            except OSError:
                c[2] = time.time() - c[1]
    if time.time() - last >= 1:
        last = time.time()
    time.sleep(0.05)
print(" ".join("%.1f" % c[2] if c[2] is not None else "open" for c in conns))
PY

start_rayd --max-conns 20 --header-seconds 2
python3 "$T/slowloris.py" "$PORT" 20 12 "$T/ready" >"$T/slow.out" 2>&1 &
sp=$!
PIDS+=($sp)
wait_until 30 test -s "$T/ready"
check slow_connections_open "$(cat "$T/ready" 2>/dev/null)" [ "$(cat "$T/ready" 2>/dev/null)" = 20 ]
# every slot is held now: this one waits unaccepted until the deadline frees some
t0=$(date +%s%N)
code=$(curl -s -m 10 -o /dev/null -w '%{http_code}' "$URL/healthz")
ms=$(( ($(date +%s%N) - t0) / 1000000 ))
echo "healthz behind 20 slow header blocks: $code in ${ms} ms"
check healthz_behind_slowloris "status $code in ${ms} ms" [ "$code" = 200 ]
wait "$sp"
echo "slow connections closed after (s): $(cat "$T/slow.out")"
# closed past the deadline (2 s) and well before the run's end (12 s)
check slow_headers_cut "$(cat "$T/slow.out")" python3 -c '
import sys
w = open(sys.argv[1]).read().split()
sys.exit(0 if len(w) == 20 and all(x != "open" and 1.9 <= float(x) <= 8 for x in w) else 1)' "$T/slow.out"
wait_until 30 metric_is 'rayd_rejections_total{reason="header_timeout"}' 20
check header_timeouts_counted "rejections $(metric 'rayd_rejections_total{reason="header_timeout"}')" \
    metric_is 'rayd_rejections_total{reason="header_timeout"}' 20
cut_lines() { [ "$(grep -c ' - /healthz 408 0 .*note=header_timeout$' "$T/rayd.err")" = 20 ]; }
wait_until 30 cut_lines
check header_timeouts_logged "$(grep -c 'header_timeout' "$T/rayd.err") lines: $(grep -v ' 200 ' "$T/rayd.err" | head -n 3)" \
    cut_lines
# one line each: libmicrohttpd's own words about the closed connection are debug
check header_timeouts_one_line "$(grep -m 2 ' http: ' "$T/rayd.err")" \
    bash -c "! grep -q ' http: ' '$T/rayd.err'"
check header_timeout_requests_counted "408: $(metric 'rayd_http_requests_total{route="none",method="other",code="408"}')" \
    metric_is 'rayd_http_requests_total{route="none",method="other",code="408"}' 20

# keepalive.py PORT: (1) a request whose header lines take a second in all;
# (2) on the same connection, after an idle 3 s (past --header-seconds), a
# second request at once; (3) then a third whose header lines trickle, one a
# second.  Prints the two statuses and when the third's connection closed.
cat >"$T/keepalive.py" <<'PY'
import socket, sys, time
s = socket.create_connection(("127.0.0.1", int(sys.argv[1])), timeout=15)
def answer():
    got = b""
    while b"\r\n\r\n" not in got:
        d = s.recv(4096)
        if not d:
            return "closed"
        got += d
    head, body = got.split(b"\r\n\r\n", 1)
    n = [int(l.split(b":")[1]) for l in head.split(b"\r\n") if l.lower().startswith(b"content-length:")]
    while n and len(body) < n[0]:
        body += s.recv(4096)
    return head.split(b" ")[1].decode()
lines = [b"GET /healthz HTTP/1.1\r\n", b"Host: x\r\n", b"X-a: 1\r\n", b"X-b: 2\r\n", b"X-c: 3\r\n", b"\r\n"]
for l in lines:
    s.sendall(l)
    time.sleep(0.2)
first = answer()
time.sleep(3)
s.sendall(b"".join(lines))
second = answer()
t0 = time.time()
s.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
closed = "open"
while time.time() - t0 < 10:
    try:
        s.sendall(b"X-a: b\r\n")
        s.settimeout(1)
        if s.recv(100) == b"":
            closed = "%.1f" % (time.time() - t0)
            break
    except socket.timeout:
        continue
    except OSError:
        closed = "%.1f" % (time.time() - t0)
        break
print(first, second, closed)
PY
python3 "$T/keepalive.py" "$PORT" >"$T/keepalive.out" 2>&1
read -r first second closed <"$T/keepalive.out"
echo "slow complete headers: $first; after an idle keep-alive wait: $second; trickling next request closed after: $closed s"
check slow_complete_headers_served "$(cat "$T/keepalive.out")" [ "$first" = 200 ]
check keepalive_idle_kept "$(cat "$T/keepalive.out")" [ "$second" = 200 ]
check keepalive_trickle_cut "$(cat "$T/keepalive.out")" python3 -c '
import sys
w = sys.argv[1]
sys.exit(0 if w != "open" and 1.5 <= float(w) <= 8 else 1)' "$closed"
stop_rayd TERM
check exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --header-seconds 0: no deadline, as before
start_rayd --header-seconds 0
python3 "$T/slowloris.py" "$PORT" 2 4 "$T/ready0" >"$T/slow0.out" 2>&1
check no_deadline_when_0 "$(cat "$T/slow0.out")" [ "$(cat "$T/slow0.out")" = "open open" ]
stop_rayd TERM
