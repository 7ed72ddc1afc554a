#!/usr/bin/env bash
# client_failover.sh -- rayd-client says when a server fails mid-frame.
#
# A node that is gone costs a frame only time: its tiles move to the other
# servers and the frame is still rayd-render's.  The user is told, with one
# warning line per server each time it starts failing (not one per tile),
# and nothing with --quiet; the end line counts only the uploads a server
# answered (the attempts on the dead one are none).  The dead server is a
# loopback port whose connections are refused for the whole test: a socket
# stays bound to it without listening (on Linux a connect() to it gets
# ECONNREFUSED), held by a process the test starts and stops by PID, so no
# other program can take the port meanwhile (a port bound and closed could
# be taken between).
source "$(dirname "$0")/lib/common.sh"

CLIENT=$RAYD_BUILD/rayd-client
[ -x "$CLIENT" ] || { echo "FAIL setup: $CLIENT missing"; exit 1; }
start_rayd --threads 1
python3 -c '
import signal, socket
s = socket.socket()  # no SO_REUSEADDR: no other socket may bind the port
s.bind(("127.0.0.1", 0))
print(s.getsockname()[1], flush=True)
signal.pause()' >"$T/dead.port" &
DEAD_PID=$!
PIDS+=("$DEAD_PID")
wait_until 60 test -s "$T/dead.port"
DEAD=http://127.0.0.1:$(cat "$T/dead.port")
# curl's 7: the connection was refused (not a timeout, nor an answer)
check dead_port_refused "$DEAD: $(curl -s -m 60 -o /dev/null -w '%{errormsg}' "$DEAD/healthz")" bash -c \
    "curl -s -m 60 -o /dev/null '$DEAD/healthz'; [ \$? = 7 ]"

scene "$T/s.json" 160 96 1 spheres
"$RENDER" "$T/s.json" -o "$T/ref.png" 2>/dev/null
timeout 120 "$CLIENT" render "$T/s.json" -o "$T/a.png" --tile 16 --parallel 4 \
    --server "$DEAD" --server "$URL" 2>"$T/a.err"
RC=$?
check failover_frame "exit $RC: $(tail -n 2 "$T/a.err")" bash -c "[ $RC = 0 ] && cmp -s '$T/ref.png' '$T/a.png'"
check failover_warned "stderr: $(head -c 400 "$T/a.err")" \
    grep -q "^rayd-client: warning: $DEAD failed: Couldn't connect to server; its tiles go to the other servers$" "$T/a.err"
sent=$(sed -n 's/.*scene sent \([0-9]*\) time.*/\1/p' "$T/a.err")
check failover_uploads_counted "end line: $(tail -n 1 "$T/a.err")" [ "$sent" = 1 ]
n=$(grep -c 'warning:' "$T/a.err")
check failover_warned_once "$n warning lines: $(grep warning "$T/a.err" | head -c 400)" [ "$n" = 1 ]

timeout 120 "$CLIENT" render "$T/s.json" -o "$T/q.png" --tile 16 --quiet \
    --server "$DEAD" --server "$URL" 2>"$T/q.err"
RC=$?
check failover_quiet "exit $RC, stderr: $(head -c 300 "$T/q.err")" \
    bash -c "[ $RC = 0 ] && [ ! -s '$T/q.err' ] && cmp -s '$T/ref.png' '$T/q.png'"
kill "$DEAD_PID"
wait "$DEAD_PID" 2>/dev/null || true # its status is the TERM's
