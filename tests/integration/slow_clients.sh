#!/usr/bin/env bash
# slow_clients.sh -- hostile and slow clients: 1,000 connections that stay
# idle or upload a body a byte at a time do not stop rayd from answering
# others (GET /healthz and a small render within a few seconds while they
# hang); --max-conns-per-ip and --max-conns close connections over the limit
# at accept and the server serves again once they are gone; the open-file
# limit was raised at start-up to hold them; a trickling upload that is
# never idle is dropped after --upload-seconds; an upload the client ends short
# (a half-close) is closed at once.  A request libmicrohttpd refuses itself
# (414, 431) is one log line, rayd's, with the status and the reason; one
# without Host is one 400 and one line.  An answer the client stops reading
# is logged with the bytes that went out and why it ended (cut_short).
source "$(dirname "$0")/lib/common.sh"

scene "$T/small.json" 64 48 1 spheres

# hold.py PORT N SECONDS READYFILE: opens N connections (half idle, half
# sending a POST body one byte every 0.5 s), writes READYFILE with the number
# held, keeps them for at most SECONDS, then reports how many the server closed.
cat >"$T/hold.py" <<'PY'
import resource, socket, sys, time
port, n, secs, ready = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
conns, slow, failed = [], [], 0
for i in range(n):
    try:
        s = socket.create_connection(("127.0.0.1", port), timeout=60)  # ends a hung case only
    except OSError:
        failed += 1
        continue
    s.setblocking(False)
    if i % 2:
        s.send(b"POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
               b"Content-Length: 100000\r\n\r\n{")
        slow.append(s)
    conns.append(s)
open(ready, "w").write("%d %d\n" % (len(conns), failed))
end = time.time() + secs
closed = 0
while time.time() < end:
    for s in slow:
        try:
            s.send(b" ")
        except OSError:
            pass
    time.sleep(0.5)
    try:
        open(ready + ".stop").close()
        break
    except OSError:
        pass
for s in conns:
    try:
        if s.recv(1) == b"":
            closed += 1
    except BlockingIOError:
        pass
    except OSError:
        closed += 1
    s.close()
print("held %d failed %d closed_by_server %d" % (len(conns), failed, closed))
PY

# --- 1,000 idle and slowly-uploading connections ------------------------------------------
# (--timeout and --header-seconds 600: the idle half must still be open
# when the test counts rayd's descriptors, however long opening them took
# on this machine; slow header blocks are slow_headers.sh's)
start_rayd --threads 2 --timeout 600 --header-seconds 600
limit=$(awk '/Max open files/ {print $4}' "/proc/$RAYD_PID/limits")
hard=$(awk '/Max open files/ {print $5}' "/proc/$RAYD_PID/limits")
check fd_limit_raised "soft $limit, hard $hard" [ "$limit" = "$hard" ]
python3 "$T/hold.py" "$PORT" 1000 300 "$T/ready" >"$T/hold.out" 2>&1 &
hp=$!
PIDS+=($hp)
wait_until 120 test -s "$T/ready"
read -r held failed <"$T/ready" || held=0
check thousand_connections_open "held $held, failed $failed" [ "${held:-0}" -ge 1000 ]
rayd_fds() { ls "/proc/$RAYD_PID/fd" | wc -l; }
wait_until 60 bash -c "[ \$(ls /proc/$RAYD_PID/fd | wc -l) -ge 1000 ]"
check server_holds_them "rayd has $(rayd_fds) descriptors open" [ "$(rayd_fds)" -ge 1000 ]
# Answered while they hang (how fast is for bench/http.sh; the curl bounds
# only end a hung case): the times are printed, not judged.
t0=$(date +%s%N)
code=$(curl -s -m 60 -o /dev/null -w '%{http_code}' "$URL/healthz")
ms=$(( ($(date +%s%N) - t0) / 1000000 ))
echo "healthz while 1,000 connections hang: $code in ${ms} ms"
check healthz_while_held "status $code in ${ms} ms" [ "$code" = 200 ]
t0=$(date +%s%N)
code=$(post_json /v1/render "$T/small.json")
ms=$(( ($(date +%s%N) - t0) / 1000000 ))
echo "64x48 render while 1,000 connections hang: $code in ${ms} ms"
check render_while_held "status $code in ${ms} ms" bash -c "[ $code = 200 ] && head -c 4 '$T/body' | grep -q PNG"
code=$(req GET /readyz)
check readyz_while_held "status $code" [ "$code" = 200 ]
touch "$T/ready.stop"
wait "$hp"
check holder_done "$(cat "$T/hold.out")" grep -q '^held 1000' "$T/hold.out"
healthz_ok() { [ "$(req GET /healthz)" = 200 ]; }
wait_until 60 healthz_ok
check alive_after_release "healthz" [ "$(req GET /healthz)" = 200 ]
stop_rayd TERM
check exit_0_after_thousand "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- --max-conns-per-ip -------------------------------------------------------------------------
# conns.py PORT N LIMIT: opens N idle connections one after another, sends a
# request on each, then reads the answers in order: "answered" when one
# comes, else "refused": closed at accept (per-IP limit) or left unaccepted
# in the listen backlog (total limit).  The server accepts in the order of
# connection, so the first LIMIT must be answered: they are given 60 s (a
# bound that only ends a hung case, never a measure of speed).  The rest
# must stay unanswered; a connection in the backlog can only show that by
# silence, so they are given 3 s, which a loaded machine only makes
# easier to pass for a server that keeps the limit.
cat >"$T/conns.py" <<'PY'
import socket, sys
port, n, limit = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
cs = []
for i in range(n):
    cs.append(socket.create_connection(("127.0.0.1", port), timeout=60))
for s in cs:
    try:
        s.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n")
    except OSError:
        pass
answered = closed = 0
for i, s in enumerate(cs):
    s.settimeout(60 if i < limit else 3)
    try:
        d = s.recv(100)
    except OSError:
        d = b""
    if d.startswith(b"HTTP/1.1 200"):
        answered += 1
    else:
        closed += 1
print(answered, closed)
for s in cs:
    s.close()
PY
start_rayd --max-conns-per-ip 8
read -r answered closed < <(python3 "$T/conns.py" "$PORT" 12 8)
check per_ip_limit "answered $answered, refused $closed of 12 (limit 8)" bash -c "[ $answered = 8 ] && [ $closed = 4 ]"
# the flood's connections are closed; rayd serves again once it has seen
# them go (a state to wait for: a loaded machine may take a while)
wait_until 60 healthz_ok
check per_ip_recovers "healthz after the flood" [ "$(req GET /healthz)" = 200 ]
check per_ip_logged "no connection-limit line" grep -qi 'limit' "$T/rayd.err"
stop_rayd TERM

start_rayd --max-conns 6
read -r answered closed < <(python3 "$T/conns.py" "$PORT" 10 6)
check total_conn_limit "answered $answered, refused $closed of 10 (limit 6)" bash -c "[ $answered = 6 ] && [ $closed = 4 ]"
wait_until 60 healthz_ok
check total_limit_recovers "healthz after the flood" [ "$(req GET /healthz)" = 200 ]
stop_rayd TERM
check exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- a URL over --max-url and headers over --max-header-bytes ----------------------------------
start_rayd --max-url 1024 --max-header-bytes 8192
code=$(req GET "/healthz?$(head -c 2000 /dev/zero | tr '\0' a)")
check max_url_414 "status $code" err_is "$T/body" 414 uri_too_long
code=$(curl -s -m 60 -o /dev/null -w '%{http_code}' -H "X-Big: $(head -c 10000 /dev/zero | tr '\0' a)" "$URL/healthz")
check max_header_bytes_431 "status $code" [ "$code" = 431 ]
code=$(curl -s -m 60 -o /dev/null -w '%{http_code}' -H "X-Ok: $(head -c 2000 /dev/zero | tr '\0' a)" "$URL/healthz")
check header_under_limit_ok "status $code" [ "$code" = 200 ]
# libmicrohttpd answers these itself: each gets an access line with the
# status it sent and is counted, the request line over the limit too
# (libmicrohttpd's 414, not rayd's --max-url one: no request reaches rayd)
code=$(curl -s -m 60 -o /dev/null -w '%{http_code}' "$URL/healthz?$(head -c 10000 /dev/zero | tr '\0' b)")
check request_line_over_header_bytes_414 "status $code" [ "$code" = 414 ]
wait_until 30 grep -q ' - - 414 0 .*note=refused_by_http_parser$' "$T/rayd.err"
check request_line_414_logged "$(grep -v ' 200 ' "$T/rayd.err" | tail -n 4)" \
    grep -q ' 127.0.0.1 - - 414 0 .* error=request_too_big note=refused_by_http_parser$' "$T/rayd.err"
wait_until 30 grep -q ' - /healthz 431 0 .*note=refused_by_http_parser$' "$T/rayd.err"
check headers_431_logged "$(grep 431 "$T/rayd.err" | tail -n 2)" \
    grep -q ' 127.0.0.1 - /healthz 431 0 .* error=request_too_big note=refused_by_http_parser$' "$T/rayd.err"
# one without Host: rayd's own 400, one answer (libmicrohttpd 0.9.75's
# strict mode wrote its status line and headers twice), one access line
got=$(raw_answers 'GET /healthz HTTP/1.1\r\nConnection: close\r\n\r\n')
check no_host_400 "answers '$got'" [ "$got" = 'HTTP/1.1 400' ]
wait_until 30 grep -q ' GET /healthz 400 [0-9]* .*error=bad_request' "$T/rayd.err"
check no_host_logged "$(grep ' 400 ' "$T/rayd.err" | tail -n 2)" \
    grep -q ' 127.0.0.1 GET /healthz 400 [0-9]* .* error=bad_request$' "$T/rayd.err"
# each refusal is one line, rayd's access line: libmicrohttpd's own words
# about it ("Error processing request (HTTP response code is 414 ...)") are
# debug lines
check refusals_one_line_each "$(grep -c 'refused_by_http_parser' "$T/rayd.err") access lines; $(grep ' http: ' "$T/rayd.err" | head -n 3)" \
    bash -c "[ \$(grep -c 'refused_by_http_parser' '$T/rayd.err') = 2 ] && [ \$(grep -c ' /healthz 400 ' '$T/rayd.err') = 1 ] && ! grep -q ' http: ' '$T/rayd.err'"
wait_until 30 metric_is 'rayd_rejections_total{reason="http_parser"}' 2
check http_parser_refusals_counted "rejections $(metric 'rayd_rejections_total{reason="http_parser"}')" \
    metric_is 'rayd_rejections_total{reason="http_parser"}' 2
check http_parser_requests_counted "414: $(metric 'rayd_http_requests_total{route="none",method="other",code="414"}'), 431: $(metric 'rayd_http_requests_total{route="none",method="other",code="431"}')" \
    bash -c "[ '$(metric 'rayd_http_requests_total{route="none",method="other",code="414"}')' = 1 ] && [ '$(metric 'rayd_http_requests_total{route="none",method="other",code="431"}')' = 1 ]"
stop_rayd TERM
check exit_0_limits "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
# at --log-level debug libmicrohttpd's own words are there too
start_rayd --max-header-bytes 8192 --log-level debug
code=$(curl -s -m 60 -o /dev/null -w '%{http_code}' -H "X-Big: $(head -c 10000 /dev/zero | tr '\0' a)" "$URL/healthz")
wait_until 30 grep -q ' - /healthz 431 0 .*note=refused_by_http_parser$' "$T/rayd.err"
check refusal_words_at_debug "status $code; $(grep ' http: ' "$T/rayd.err" | head -n 2)" \
    grep -q ' debug http: Error processing request (HTTP response code is 431 ' "$T/rayd.err"
stop_rayd TERM

# --- a trickling upload is dropped after --upload-seconds, though never idle -------------------
start_rayd --upload-seconds 2 --timeout 30
python3 - "$PORT" >"$T/trickle.txt" <<'PY'
import socket, sys, time
t0 = time.time()  # before the connection: what is measured is never less than rayd's own clock
s = socket.create_connection(("127.0.0.1", int(sys.argv[1])), timeout=10)
s.sendall(b"POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
          b"Content-Length: 100000\r\n\r\n{")
closed = None
while time.time() - t0 < 60:
    try:
        s.send(b" ")
        s.settimeout(0.3)
        if s.recv(100) == b"":
            closed = time.time() - t0
            break
    except socket.timeout:
        continue
    except OSError:
        closed = time.time() - t0
        break
print("closed_after %.1f" % closed if closed is not None else "still_open")
PY
echo "trickling upload: $(cat "$T/trickle.txt") s"
check trickle_dropped "$(cat "$T/trickle.txt")" python3 -c '
import sys
w = open(sys.argv[1]).read().split()
sys.exit(0 if w[0] == "closed_after" and float(w[1]) >= 1.5 else 1)' "$T/trickle.txt"
wait_until 30 grep -q 'note=upload_too_slow' "$T/rayd.err"
check trickle_logged "no upload_too_slow line" grep -q 'note=upload_too_slow' "$T/rayd.err"
check normal_upload_ok "status" [ "$(post_json /v1/render "$T/small.json")" = 200 ]
stop_rayd TERM
check exit_0_trickle "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]

# A client that shuts its side (half-close) before its declared body is all
# sent can never send the rest: rayd closes at once, as for a full close,
# however the shutdown arrives -- with the body's last bytes in one read
# (which libmicrohttpd's edge-triggered loop alone missed until --timeout)
# or on its own.  No time is judged: rayd's --timeout (300 s) is past the
# client's own (60 s), so a connection that rayd left open until --timeout
# ends with the client's timeout ("open"), one it closed with end of file.
start_rayd --timeout 300
cat >"$T/halfclose.py" <<'PY'
import socket, sys, time
port, pause = int(sys.argv[1]), float(sys.argv[2])
s = socket.create_connection(("127.0.0.1", port), timeout=60)
s.sendall(b"POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
          b"Content-Length: 1000\r\n\r\n{\"camera\": ")
if pause:  # no call at all between the two, not even sleep(0)
    time.sleep(pause)
s.shutdown(socket.SHUT_WR)
t0 = time.time()
got, end = b"", "closed"
try:
    while True:
        d = s.recv(4096)
        if not d:
            break
        got += d
except socket.timeout:
    end = "open"
except OSError:
    pass
print("%.1f %d %s" % (time.time() - t0, len(got), end))
PY
for pause in 0 0 0 0 0 0.2; do
    python3 "$T/halfclose.py" "$PORT" "$pause"
done >"$T/halfclose.txt"
echo "half-closed uploads (seconds to close, bytes answered, how it ended): $(tr '\n' ' ' <"$T/halfclose.txt")"
check half_closed_upload_closed "$(tr '\n' ' ' <"$T/halfclose.txt")" python3 -c '
import sys
rows = [l.split() for l in open(sys.argv[1])]
sys.exit(0 if len(rows) == 6 and all(b == "0" and e == "closed" for s, b, e in rows) else 1)' "$T/halfclose.txt"
# (the access line may come a moment after the client saw the close)
half_closed_logged() { [ "$(grep -Ec ' 499 .*note=(aborted|upload_incomplete)' "$T/rayd.err")" = 6 ]; }
wait_until 30 half_closed_logged
check half_closed_upload_logged "$(grep -c 'note=timeout' "$T/rayd.err") timeouts" half_closed_logged
check half_closed_no_internal_error "$(grep -m1 'internal error' "$T/rayd.err")" \
    bash -c "! grep -q 'Application reported internal error' '$T/rayd.err'"
check after_half_close_ok "status" [ "$(post_json /v1/render "$T/small.json")" = 200 ]
stop_rayd TERM
check exit_0_half_close "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- an answer the client stops reading: the access line says how much went out ---------
# A client reads the first 256 KiB of an 18 MB answer (a sample range's sums)
# with a small receive buffer, then closes.  The access line keeps the 200
# it was sent with, but its bytes are those that went out (less than the
# whole) and cut_short says why it ended, with size the whole body's bytes;
# a client that reads it all gets a line with the whole size and no
# cut_short.  (Once the line said 200 and the full size.)
scene "$T/big.json" 1024 768 1 spheres
start_rayd --threads 2
cat >"$T/partial.py" <<'PY'
import socket, sys
port, path, limit = int(sys.argv[1]), sys.argv[2], int(sys.argv[3])
body = open(sys.argv[4], "rb").read()
s = socket.socket()
if limit >= 0:  # a reader that stops: a small window, so less waits in its buffer
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8192)
s.settimeout(120)  # ends a hung case only
s.connect(("127.0.0.1", port))
s.sendall(b"POST %s HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
          b"Content-Length: %d\r\nConnection: close\r\n\r\n" % (path.encode(), len(body)) + body)
got = bytearray()  # (bytes += would copy the whole answer at each read)
while limit < 0 or len(got) < limit:
    d = s.recv(65536)
    if not d:
        break
    got += d
s.close()
print(len(got))
PY
sums=/v1/render?format=sums\&samples=0-1
read_bytes=$(python3 "$T/partial.py" "$PORT" "$sums" 262144 "$T/big.json")
cut_line() { grep -E " POST /v1/render\?format=sums&samples=0-1 200 [0-9]+ .* cut_short=[a-z_]+ size=[0-9]+" "$T/rayd.err"; }
wait_until 30 cut_line
line=$(cut_line | head -1)
echo "answer cut short at $read_bytes bytes read: $line"
check cut_short_logged "no cut_short line: $(grep 'format=sums' "$T/rayd.err" | head -2)" test -n "$line"
check cut_short_bytes_less "$line" python3 -c '
import re, sys
m = re.search(r" 200 (\d+) .* cut_short=(client_closed|send_error|read_error) size=(\d+)", sys.argv[1])
sys.exit(0 if m and 200000 <= int(m.group(1)) < int(m.group(3))
         and 0 <= int(m.group(3)) - 1024 * 768 * 24 < 256 else 1)' "$line"
size=$(sed -E 's/.* size=([0-9]+)$/\1/' <<<"$line")
full=$(python3 "$T/partial.py" "$PORT" "$sums" -1 "$T/big.json")
full_line() { grep -E " POST /v1/render\?format=sums&samples=0-1 200 $size " "$T/rayd.err"; }
wait_until 30 full_line
check whole_answer_logged_whole "read $full; $(grep 'format=sums' "$T/rayd.err" | tail -1)" \
    bash -c "grep -E ' POST /v1/render\?format=sums&samples=0-1 200 $size ' '$T/rayd.err' | grep -vq cut_short"
stop_rayd TERM
check exit_0_cut_short "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
