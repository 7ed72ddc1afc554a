#!/usr/bin/env bash
# durable_forget.sh -- a job forgotten under --data-dir (--job-ttl) stays
# forgotten across kill -9, and its files leave the disk budget whole.
#
# Before, the store unlinked a forgotten job's files first and deleted its
# rows after, in two commits: rayd killed in between left a "done" row
# whose file was gone, and the next start rendered the forgotten job again
# (succeeded, a new TTL).  And a forgotten frame-range job gave back to
# --max-disk the bytes of its first frame only, so the rest were counted
# for ever and newer images were evicted (410) under a budget they fit.
source "$(dirname "$0")/lib/common.sh"

kill9() { kill -KILL "$RAYD_PID" 2>/dev/null; wait "$RAYD_PID" 2>/dev/null; RAYD_PID=; }
cat >"$T/anim.json" <<'JSON'
{"animation": {"start": 0, "end": 3, "fps": 10},
 "render": {"width": 32, "height": 32, "samples": 1},
 "camera": {"look_at": [0, 0.5, 0], "keyframes": [{"frame": 0, "position": [0, 1.5, 5]},
                                                   {"frame": 3, "position": [4, 2, 2]}]},
 "lights": [{"type": "point", "position": [4, 5, 4]}],
 "objects": [{"type": "plane", "material": {"color": [0.6, 0.6, 0.6]}},
             {"type": "sphere", "center": [0, 0.5, 0], "radius": 0.5,
              "material": {"color": [0.9, 0.3, 0.2]}}]}
JSON
scene "$T/p1.json" 32 32 1 spheres 1
scene "$T/p2.json" 32 32 1 spheres 2
# post NAME QUERY: the job's id in $T/NAME.id
post() { post_json "/v1/jobs$2" "$T/$1.json" >/dev/null && jfield "$T/body" id >"$T/$1.id"; }
jid() { cat "$T/$1.id"; }
gone() { [ "$(req GET "/v1/jobs/$1")" != 200 ]; }
bytes() { stat -c %s "$@" | awk '{ s += $1 } END { print s }'; }

# ---- kill -9 while a forgotten job's files go (gdb stops rayd after the first unlink: the
# forget's; a job's render and record unlink nothing).  gdb is attached before the job is posted,
# so its 2 s TTL cannot run out first; rayd is killed whatever gdb managed.
D=$T/d1
start_rayd --threads 1 --data-dir "$D" --job-ttl 2
attached=false
if command -v gdb >/dev/null; then
    timeout 120 gdb -q -p "$RAYD_PID" -batch -ex 'break unlink' -ex continue -ex finish \
        -ex "shell kill -KILL $RAYD_PID" >"$T/gdb.out" 2>&1 &
    gdbpid=$!
    # traced, and running again: the breakpoint is in (gdb's own output is buffered)
    resumed() { awk '/^State:/ {s = $2} /^TracerPid:/ {t = $2} END {exit !(t > 0 && s != "t")}' \
        "/proc/$RAYD_PID/status"; }
    wait_until 60 resumed && attached=true
fi
if ! $attached; then # no gdb, or no ptrace here (Yama, a container)
    echo "SKIP forget_kill: gdb could not stop rayd: $(tail -2 "$T/gdb.out" 2>/dev/null | tr '\n' ' ')"
    [ -n "${gdbpid:-}" ] && kill "$gdbpid" 2>/dev/null
    kill9
else
    post p1 ""
    wait "$gdbpid"
    kill9
    check forget_kill_stopped "$(tail -3 "$T/gdb.out")" grep -q "Breakpoint 1," "$T/gdb.out"
    start_rayd --threads 1 --data-dir "$D" --job-ttl 600
    code=$(req GET "/v1/jobs/$(jid p1)")
    check forget_kill_stays_forgotten "status $code: $(head -c 200 "$T/body")" [ "$code" = 404 ]
    kill9
fi

# ---- --max-disk after a frame-range job is forgotten -----------------------------------
start_rayd --threads 1 --data-dir "$T/d2"
post anim "?frames=0-3" && post p1 "" && post p2 ""
for n in anim p1 p2; do wait_until 60 job_state_is "$(jid $n)" succeeded; done
F=$(bytes "$T/d2/results/$(jid anim)"-*.png)
P=$(bytes "$T/d2/results/$(jid p1).png" "$T/d2/results/$(jid p2).png")
kill9
# room for the frames, or for both plain images, never for the frames' rest and both
# (a TTL that forgets the frame-range job, not the two small jobs rendered after it)
budget=$(( (F > P ? F : P) + 64 ))
check forget_disk_setup "frames $F bytes, plain $P" [ $((F * 3 / 4 + P)) -gt "$budget" ]
start_rayd --threads 1 --data-dir "$T/d3" --job-ttl 8 --max-disk "$budget"
post anim "?frames=0-3"
wait_until 60 job_state_is "$(jid anim)" succeeded
wait_until 30 gone "$(jid anim)"
wait_until 10 bash -c "! ls '$T/d3/results' | grep -q ."
post p1 "" && post p2 ""
ended() { job_state_is "$1" succeeded || job_state_is "$1" evicted; }
for n in p1 p2; do wait_until 60 ended "$(jid $n)"; done
for n in p1 p2; do
    code=$(req GET "/v1/jobs/$(jid $n)/image.png")
    check "forget_disk_${n}_kept" "status $code: $(head -c 200 "$T/body" | tr -c "[:print:]" .)" [ "$code" = 200 ]
done
exit $((NFAIL > 0))
