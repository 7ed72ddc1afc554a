#!/usr/bin/env bash
# jobs_durable.sh -- with --data-dir a job survives kill -9: the restart
# matrix, the disk budget (--max-disk, 410), and --data-dir's checks.
#
# rayd is killed with SIGKILL while a job is queued (held at the test
# gate), while one renders (the gate let one tile through), after jobs
# ended (succeeded, cancelled, one with its EXR), and during an image's
# write (RAYD_TEST_STORE_STALL=1 stops the store between writing the
# temporary file and renaming it).  After each restart every job is still
# there under its id: the finished ones served byte for byte as before,
# the unfinished ones queued again and rendered to the same bytes a
# synchronous render gives, nothing torn (no .tmp is left, no image
# differs).  On f1aafc1 rayd had no --data-dir, and a restarted rayd
# answered 404 job_unknown for every job.
source "$(dirname "$0")/lib/common.sh"

D=$T/data
post_job() { # post_job NAME [QUERY]: POSTs $T/NAME.json; the id in $T/NAME.id
    local code
    code=$(post_json "/v1/jobs${2:-}" "$T/$1.json")
    jfield "$T/body" id >"$T/$1.id"
    [ "$code" = 202 ]
}
jid() { cat "$T/$1.id"; }
kill9() { kill -KILL "$RAYD_PID" 2>/dev/null; wait "$RAYD_PID" 2>/dev/null; RAYD_PID=; }
# same_as_render NAME FILE: FILE has the bytes POST /v1/render gives for NAME's scene
same_as_render() {
    [ "$(post_json /v1/render "$T/$1.json")" = 200 ] && cmp -s "$T/body" "$2"
}

# ---- bad --data-dir values ---------------------------------------------------------
bad_start() { # bad_start STATUS TEXT ARGS...: rayd refuses to start, saying TEXT
    local want=$1 text=$2 rc
    shift 2
    timeout 30 "$RAYD" --bind 127.0.0.1 --port 0 "$@" >"$T/bad.out" 2>"$T/bad.err"
    rc=$?
    [ "$rc" = "$want" ] && grep -q -- "$text" "$T/bad.err" && ! [ -s "$T/bad.out" ]
}
: >"$T/afile"
check datadir_is_file "$(cat "$T/bad.err" 2>/dev/null)" bad_start 1 "not a directory" --data-dir "$T/afile"
check datadir_cannot_make "$(cat "$T/bad.err")" bad_start 1 "cannot use or create" \
    --data-dir "$T/no/such/parent"
check datadir_empty "$(cat "$T/bad.err")" bad_start 2 "is empty" --data-dir ""
check max_disk_needs_dir "$(cat "$T/bad.err")" bad_start 2 "needs --data-dir" --max-disk 10M
check max_disk_bad "$(cat "$T/bad.err")" bad_start 2 "--max-disk takes bytes" \
    --data-dir "$D" --max-disk 10Q

# ---- the kill -9 matrix ------------------------------------------------------------
start_rayd --threads 1 --test-gate 0 --data-dir "$D"
check datadir_made "no $D/jobs.db after a start with it" test -f "$D/jobs.db"
check datadir_second_rayd "$(cat "$T/bad.err")" bad_start 1 "another rayd (PID $RAYD_PID) uses it" --data-dir "$D"

# distinct bytes for each scene (a tag of spaces per name), so no two share
# a task; 32x32 is one tile, 96x96 (run) several
i=1
for n in done exr cancel queue; do scene "$T/$n.json" 32 32 1 spheres $i; i=$((i + 1)); done
scene "$T/run.json" 96 96 1 spheres 5

post_job done && post_job exr "?format=exr" && post_job cancel
check matrix_posted "$(head -c 200 "$T/body")" test -s "$T/cancel.id"
req DELETE "/v1/jobs/$(jid cancel)" >/dev/null
gate open
wait_until 60 job_state_is "$(jid done)" succeeded
wait_until 60 job_state_is "$(jid exr)" succeeded
gate 0
req GET "/v1/jobs/$(jid done)/image.png" >/dev/null && cp "$T/body" "$T/done.before"
req GET "/v1/jobs/$(jid exr)/image.exr" >/dev/null && cp "$T/body" "$T/exr.before"
check matrix_done_before "no PNG" is_png "$T/done.before"
# one renders: the gate lets its one tile start and holds the next job's
post_job run
gate 1
wait_until 60 gate_is started 3
post_job queue
scene "$T/prog.json" 32 32 4 spheres 12
post_job prog "?progressive=1"
wait_until 60 job_state_is "$(jid queue)" queued
check matrix_run_running "state $(jfield "$T/body" state)" job_state_is "$(jid run)" running

kill9
# no result cache: the synchronous render compared with is rendered anew
start_rayd --threads 1 --test-gate 0 --data-dir "$D" --result-cache-mb 0
for n in done exr cancel run queue prog; do
    code=$(req GET "/v1/jobs/$(jid $n)")
    check "restart_${n}_kept" "status $code: $(head -c 200 "$T/body")" [ "$code" = 200 ]
done
check restart_done_state "$(head -c 200 "$T/body")" job_state_is "$(jid done)" succeeded
check restart_cancel_state "$(head -c 200 "$T/body")" job_state_is "$(jid cancel)" canceled
check restart_queued_again "$(head -c 200 "$T/body")" job_state_is "$(jid run)" queued
req GET "/v1/jobs/$(jid done)/image.png" >/dev/null
check restart_done_same_bytes "image differs after the restart" cmp -s "$T/body" "$T/done.before"
curl -s -m 30 "$URL/v1/jobs/$(jid done)/events" >"$T/events"
check restart_events_done "$(head -c 300 "$T/events")" grep -q "event: done" "$T/events"
req GET "/v1/jobs/$(jid exr)/image.exr" >/dev/null
check restart_exr_same_bytes "EXR differs after the restart" cmp -s "$T/body" "$T/exr.before"
gate open
wait_until 60 job_state_is "$(jid run)" succeeded
wait_until 60 job_state_is "$(jid queue)" succeeded
wait_until 60 job_state_is "$(jid prog)" succeeded
code=$(req GET "/v1/jobs/$(jid prog)/image.png")
check restart_progressive_rendered "status $code: $(head -c 200 "$T/body" | tr -c '[:print:]' .)" \
    bash -c "[ $code = 200 ] && [ '$(png_size "$T/body" 2>/dev/null)' = 32x32 ]"
for n in run queue; do
    req GET "/v1/jobs/$(jid $n)/image.png" >/dev/null && cp "$T/body" "$T/$n.png"
    check "restart_${n}_rendered" "$(head -c 200 "$T/$n.png" | tr -c '[:print:]' .)" \
        same_as_render "$n" "$T/$n.png"
done

# after they finished: a second kill keeps them all, still the same bytes
kill9
start_rayd --threads 1 --data-dir "$D"
req GET "/v1/jobs/$(jid run)/image.png" >/dev/null
check restart_twice_same_bytes "image differs" cmp -s "$T/body" "$T/run.png"
req GET /v1/jobs >/dev/null
check restart_list_all "$(head -c 300 "$T/body")" python3 - "$T/body" \
    "$(jid prog)" "$(jid queue)" "$(jid run)" "$(jid cancel)" "$(jid exr)" "$(jid done)" <<'PY'
import json, sys
ids = [j["id"] for j in json.load(open(sys.argv[1]))["jobs"]]
sys.exit(0 if ids == sys.argv[2:] else 1)
PY

# during a write: the store stops between the temporary file and its rename
kill9
RAYD_TEST_STORE_STALL=1 start_rayd --threads 1 --test-gate open --data-dir "$D"
scene "$T/torn.json" 48 48 1 spheres 9
post_job torn
tmp_there() { test -e "$D/results/$(jid torn).png.tmp"; }
wait_until 60 tmp_there
check write_stalled "no $D/results/$(jid torn).png.tmp" tmp_there
kill9
# the gate is shut so the job queued again cannot begin a new write before the check
start_rayd --threads 1 --test-gate 0 --data-dir "$D" --result-cache-mb 0
check write_tmp_swept "$(ls "$D/results")" bash -c "! ls '$D/results' | grep -q tmp"
gate open
wait_until 60 job_state_is "$(jid torn)" succeeded
req GET "/v1/jobs/$(jid torn)/image.png" >/dev/null && cp "$T/body" "$T/torn.png"
check write_rendered_whole "$(head -c 100 "$T/torn.png" | tr -c '[:print:]' .)" \
    same_as_render torn "$T/torn.png"
check write_file_whole "file differs from the image served" \
    cmp -s "$D/results/$(jid torn).png" "$T/torn.png"

# a DELETE answers once the job's end is on disk: its 200 came at once before, and a kill while
# the store was behind (here stalled for good on another job's image) brought the cancelled job
# back, queued, at the restart
kill9
RAYD_TEST_STORE_STALL=1 start_rayd --threads 1 --test-gate 0 --data-dir "$D"
scene "$T/first.json" 32 32 1 spheres 21
scene "$T/second.json" 96 96 1 spheres 22
post_job first
post_job second
gate 1
first_tmp() { test -e "$D/results/$(jid first).png.tmp"; }
wait_until 60 first_tmp
code=$(curl -s -m 3 -o "$T/del.out" -w '%{http_code}' -X DELETE "$URL/v1/jobs/$(jid second)")
kill9
start_rayd --threads 1 --test-gate 0 --data-dir "$D"
req GET "/v1/jobs/$(jid second)" >/dev/null
state=$(jfield "$T/body" state)
check delete_answered_on_disk "DELETE $code before the kill, the job $state after it" \
    bash -c '[ "$0" != 200 ] || [ "$1" = canceled ]' "$code" "$state"
code=$(req DELETE "/v1/jobs/$(jid second)")
kill9
start_rayd --threads 1 --test-gate 0 --data-dir "$D"
req GET "/v1/jobs/$(jid second)" >/dev/null
check delete_stays_after_kill "DELETE $code, then $(head -c 200 "$T/body")" \
    bash -c '[ "$0" = 200 ] && [ "$1" = canceled ]' "$code" "$(jfield "$T/body" state)"

# a drain (SIGTERM) is no end: a job it cancels is queued again at the next start
kill9
start_rayd --threads 1 --test-gate 0 --data-dir "$D" --drain-seconds 0
scene "$T/drain.json" 32 32 1 spheres 11
post_job drain
stop_rayd TERM
start_rayd --threads 1 --data-dir "$D"
wait_until 60 job_state_is "$(jid drain)" succeeded
check drain_requeued "$(head -c 200 "$T/body")" job_state_is "$(jid drain)" succeeded

# six drains in a row (deploys) count no attempt: a one-image job and a frame-range job queued
# through all six then render (the one-image job failed at the fifth, "rayd stopped 5 times")
cat >"$T/anim.json" <<'JSON'
{"animation": {"start": 1, "end": 3, "fps": 10}, "render": {"width": 24, "height": 24},
 "camera": {"look_at": [0, 0.5, 0], "keyframes": [{"frame": 1, "position": [0, 1.5, 5]},
                                                   {"frame": 3, "position": [3, 2, 3]}]},
 "lights": [{"type": "point", "position": [4, 5, 4]}],
 "objects": [{"type": "sphere", "center": [0, 0.5, 0], "radius": 0.5}]}
JSON
scene "$T/deploy.json" 32 32 1 spheres 12
stop_rayd TERM
start_rayd --threads 1 --test-gate 0 --data-dir "$D" --drain-seconds 0
post_job deploy
post_job anim
for _ in 1 2 3 4 5 6; do
    stop_rayd TERM
    start_rayd --threads 1 --test-gate 0 --data-dir "$D" --drain-seconds 0
done
gate open
wait_until 60 job_state_is "$(jid deploy)" succeeded
check drains_no_attempt "$(head -c 300 "$T/body")" job_state_is "$(jid deploy)" succeeded
wait_until 60 job_state_is "$(jid anim)" succeeded
check drains_no_attempt_frames "$(head -c 300 "$T/body")" job_state_is "$(jid anim)" succeeded

# a start that fails once the jobs are back (the port in use) leaves them queued, no attempt
# counted: five such starts failed the job ("rayd stopped 5 times"), and one whose store thread
# wrote the pool's cancels in time left every job cancelled
scene "$T/portjob.json" 32 32 1 spheres 14
stop_rayd TERM
start_rayd --threads 1 --test-gate 0 --data-dir "$D" --drain-seconds 0
post_job portjob
stop_rayd TERM
python3 -c 'import socket, time
s = socket.socket(); s.bind(("127.0.0.1", 0)); s.listen()
print(s.getsockname()[1], flush=True); time.sleep(120)' >"$T/busy.port" &
busy=$!
wait_until 10 test -s "$T/busy.port"
for _ in 1 2 3 4 5; do
    timeout 60 "$RAYD" --bind 127.0.0.1 --port "$(head -1 "$T/busy.port")" --threads 1 --test-gate 0 \
        --data-dir "$D" >/dev/null 2>"$T/busy.err"
done
check port_in_use_start_fails "exit $?: $(tail -2 "$T/busy.err")" grep -q "queued again" "$T/busy.err"
kill "$busy"
wait "$busy" 2>/dev/null
start_rayd --threads 1 --data-dir "$D"
wait_until 60 job_state_is "$(jid portjob)" succeeded
check failed_start_keeps_jobs "$(head -c 300 "$T/body")" job_state_is "$(jid portjob)" succeeded

# five kills while unfinished do count: both kinds of job fail, saying so, and a failed job
# does not say it got to the end (it said progress 1, every tile done)
scene "$T/poison.json" 32 32 1 spheres 13
sed 's/\[4, 5, 4\]/[4, 6, 4]/' "$T/anim.json" >"$T/anim2.json" # another scene
stop_rayd TERM
start_rayd --threads 1 --test-gate 0 --data-dir "$D"
post_job poison
post_job anim2
for _ in 1 2 3 4 5; do
    kill9
    start_rayd --threads 1 --test-gate 0 --data-dir "$D"
done
gave_up() { req GET "/v1/jobs/$(jid "$1")" >/dev/null && job_state_is "$(jid "$1")" failed &&
    grep -q 'rayd stopped 5 times while the job was unfinished' "$T/body"; }
check kills_fail_job "$(req GET "/v1/jobs/$(jid poison)"; head -c 400 "$T/body")" gave_up poison
check kills_failed_no_progress "$(head -c 400 "$T/body")" \
    eval '[ "$(json "$T/body" '"'"'j["progress"] == 0 and j["tiles_done"] == 0'"'"')" = True ]'
check kills_fail_frames_job "$(req GET "/v1/jobs/$(jid anim2)"; head -c 400 "$T/body")" gave_up anim2

# ---- --max-disk: the oldest finished image goes first, and says so -----------------
kill9
rm -rf "$D"
start_rayd --threads 1 --data-dir "$D" --max-disk 1
for n in d1 d2; do
    scene "$T/$n.json" 32 32 1 spheres "$((${#n} + 20 + ${n#d}))"
    post_job "$n"
    wait_until 60 job_state_is "$(jid $n)" succeeded
done
evicted() { [ "$(req GET "/v1/jobs/$(jid d1)/image.png")" = 410 ]; }
wait_until 60 evicted
code=$(req GET "/v1/jobs/$(jid d1)/image.png")
check disk_evicted_410 "status $code: $(head -c 300 "$T/body")" err_is "$T/body" 410 result_evicted
check disk_evicted_says_why "$(head -c 300 "$T/body")" grep -q -- "--max-disk" "$T/body"
code=$(req GET "/v1/jobs/$(jid d2)/image.png")
check disk_newest_kept "status $code" [ "$code" = 200 ]
check disk_file_gone "$(ls "$D/results")" bash -c "! ls '$D/results' | grep -q '$(jid d1)'"
kill9
start_rayd --threads 1 --data-dir "$D" --max-disk 1
code=$(req GET "/v1/jobs/$(jid d1)")
check disk_evicted_after_restart "status $code: $(head -c 300 "$T/body")" \
    err_is "$T/body" 410 result_evicted
code=$(req GET "/v1/jobs/$(jid d2)/image.png")
check disk_kept_after_restart "status $code" [ "$code" = 200 ]

# the TTL counts from the end, across a restart: an ended job older than it goes
kill9
start_rayd --threads 1 --data-dir "$D" --job-ttl 1
gone() { [ "$(req GET "/v1/jobs/$(jid d2)")" != 200 ]; }
wait_until 60 gone
check ttl_across_restart "status $(req GET "/v1/jobs/$(jid d2)")" gone
check ttl_file_deleted "$(ls "$D/results")" bash -c "! ls '$D/results' | grep -q png"

# ---- a tampered store: rows rayd did not write are left out ---------------------------
# a row whose id leads out of results/ (its expiry would delete that file), and a frame
# range past --max-frames (it would take gigabytes before the port opens)
kill9
D2=$T/tampered
start_rayd --threads 1 --data-dir "$D2"
scene "$T/t1.json" 32 32 1 spheres 30
post_job t1
wait_until 60 job_state_is "$(jid t1)" succeeded
kill9
echo victim >"$T/victim.png"
python3 - "$D2/jobs.db" "$(jid t1)" <<'PY'
import sqlite3, sys
db = sqlite3.connect(sys.argv[1])
db.execute("CREATE TEMP TABLE t AS SELECT * FROM jobs WHERE id = ?", (sys.argv[2],))
db.execute("UPDATE t SET id = '../../victim', seq = seq + 1000")
db.execute("INSERT INTO jobs SELECT * FROM t")
db.execute("UPDATE t SET id = ?, seq = seq + 1000, state = 'queued', frame_first = 0, frame_last = 50000000, fps = 24",
           ("f" * 32,))
db.execute("INSERT INTO jobs SELECT * FROM t")
db.commit()
PY
start_rayd --threads 1 --data-dir "$D2" --job-ttl 1
sleep 3
check tampered_file_kept "$(ls "$T")" test -e "$T/victim.png"
check tampered_rows_said "$(grep -c 'left out' "$T/rayd.err")" bash -c \
    "grep -q \"job row '../../victim' is left out: its id is not 32 hex\" '$T/rayd.err' &&
     grep -q \"job row 'ffff.*' is left out: its frames are past --max-frames\" '$T/rayd.err'"
req GET /v1/jobs >/dev/null
check tampered_rows_not_listed "$(head -c 300 "$T/body")" bash -c "! grep -q 'victim\|ffffffff' '$T/body'"

# ---- without --data-dir: memory only, as before --------------------------------------
kill9
start_rayd --threads 1
post_job d1
wait_until 60 job_state_is "$(jid d1)" succeeded
kill9
start_rayd --threads 1
code=$(req GET "/v1/jobs/$(jid d1)")
check memory_only_forgets "status $code" [ "$code" = 404 ]

exit $((NFAIL > 0))
