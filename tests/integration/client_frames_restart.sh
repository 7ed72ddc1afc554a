#!/usr/bin/env bash
# client_frames_restart.sh -- rayd-client job follows a frame-range job
# across a kill -9 and restart of a rayd with --data-dir: the server gone
# for a few seconds (its event stream broken, then its status refused) is
# asked again, not given up on, and once it is back every frame is written,
# each rayd-render --frame K's bytes.  Every process is stopped by its PID.
source "$(dirname "$0")/lib/common.sh"

D=$T/data
cp "$RAYD_ROOT/tests/integration/lib/anim4.json" "$T/anim.json" # frames 0-3, 64x32
start_rayd --threads 1 --test-gate 0 --data-dir "$D"
"$RAYD_BUILD/rayd-client" job "$T/anim.json" -o "$T/out-%d.png" --server "$URL" --timeout 60 \
    >"$T/client.out" 2>"$T/client.err" &
CLIENT=$!
PIDS+=("$CLIENT")
wait_until 60 grep -q 'frames 0-3' "$T/client.err"
gate 1 # frame 0 (one tile)
wait_until 60 test -s "$T/out-0.png"
kill -KILL "$RAYD_PID"
wait "$RAYD_PID" 2>/dev/null
sleep 5 # the stream gives up (three tries a second apart); the client polls a dead port
check client_waits "$(cat "$T/client.err")" kill -0 "$CLIENT"
start_rayd --threads 1 --test-gate open --data-dir "$D" --port "$PORT"
wait "$CLIENT"
rc=$?
check client_exit_0 "exit $rc: $(cat "$T/client.err")" [ "$rc" = 0 ]
check client_said_asking_again "$(cat "$T/client.err")" grep -q 'asking again for 60 s' "$T/client.err"
n=0
for k in 0 1 2 3; do
    "$RENDER" "$T/anim.json" --frame "$k" -o "$T/cli-$k.png" -q --threads 1
    cmp -s "$T/out-$k.png" "$T/cli-$k.png" && n=$((n + 1))
done
check frames_as_cli "$n of 4" [ "$n" = 4 ]
stop_rayd
exit $NFAIL
