#!/usr/bin/env bash
# client_frames.sh -- rayd-client job of an animated scene: a frame-range
# job followed to its end.  Each frame written to -o's %d pattern is the
# bytes of rayd-render --frame K (PNG and OpenEXR), as many files as frames
# and no temporary file left; --video writes the job's MP4 (its frames
# counted by ffprobe); without --frames the whole animation; the progress
# lines when stderr is no terminal, the bar when it is one; the usage errors (exit 2, nothing
# sent): an -o without %d, a bad pattern, frames outside the animation, a
# still scene, a bad --video; a failed job exits 1 with the server's error
# naming the frame (and the value at fault by its JSON Pointer); Ctrl-C cancels the job and exits 130; a hostile server
# (a job that lies, frames of another size, escapes) is checked, not trusted.
source "$(dirname "$0")/lib/common.sh"
CLIENT=$RAYD_BUILD/rayd-client

cp "$RAYD_ROOT/tests/integration/lib/anim.json" "$T/anim.json" # frames 2-9, 48x32
cat >"$T/short.json" <<'EOF'
{"animation": {"start": 2, "end": 5},
 "render": {"width": 16, "height": 16, "samples": 1},
 "camera": {"look_at": [0, 0.5, 0], "keyframes": [{"frame": 2, "position": [0, 1.5, 5]},
                                                   {"frame": 5, "position": [4, 2, 2]}]},
 "lights": [{"type": "point", "position": [4, 5, 4]}],
 "objects": [{"type": "plane", "material": {"color": [0.6, 0.6, 0.6]}}]}
EOF
scene "$T/still.json" 32 32 1 spheres 3

start_rayd --threads 2 --test-gate 0
gate open
jobs_now() { req GET "/v1/jobs?limit=100" >/dev/null && json "$T/body" 'len(j["jobs"])'; }

# ---- frames 3-6 and the video ------------------------------------------------------------
mkdir "$T/a"
"$CLIENT" job "$T/anim.json" -o "$T/a/shot-%04d.png" --frames 3-6 --video "$T/a/shot.mp4" \
    --server "$URL" 2>"$T/a.err" </dev/null
rc=$?
check frames_exit_0 "exit $rc: $(tail -3 "$T/a.err")" [ "$rc" = 0 ]
check frames_file_count "$(ls "$T/a")" eval '[ "$(ls "$T/a" | wc -l)" = 5 ] &&
    [ "$(ls "$T/a" | grep -c "^shot-000[3-6]\.png$")" = 4 ] && ! ls "$T/a" | grep -q part'
for k in 3 4 5 6; do
    timeout 120 "$RENDER" "$T/anim.json" --frame "$k" -o "$T/cli-$k.png" -q --threads 1
    check "frame_${k}_as_rayd_render" "shot-000$k.png differs" cmp -s "$T/a/shot-000$k.png" "$T/cli-$k.png"
done
check frames_differ "frames 3 and 6 are the same image" eval '! cmp -s "$T/a/shot-0003.png" "$T/a/shot-0006.png"'
probe=$(ffprobe -v error -select_streams v:0 -count_frames -show_entries \
    stream=codec_name,width,height,nb_read_frames -of csv=p=0 "$T/a/shot.mp4" 2>&1)
check video_frames "$probe" eval '[ "$probe" = "h264,48,32,4" ]'
# not a terminal: a line a frame, counted up, with an ETA; then the totals
grep '^rayd-client: frame ' "$T/a.err" | sed 's/.*(frames \([0-9]*\)\/\([0-9]*\), ETA .*)$/\1\/\2/' >"$T/a.counts"
check progress_lines "$(cat "$T/a.err")" eval '[ "$(tr "\n" " " <"$T/a.counts")" = "1/4 2/4 3/4 4/4 " ] &&
    grep -q "^rayd-client: frame [3-6] -> $T/a/shot-000[3-6].png (frames 1/4, ETA [0-9][0-9hms]*)$" "$T/a.err" &&
    grep -q "^rayd-client: wrote 4 frames to $T/a/shot-%04d.png$" "$T/a.err" &&
    grep -q "^rayd-client: wrote $T/a/shot.mp4$" "$T/a.err"'
"$CLIENT" job "$T/anim.json" -o "$T/a/q-%d.png" --frames 4-5 --server "$URL" -q 2>"$T/q.err" </dev/null
check quiet_says_nothing "exit $?, $(cat "$T/q.err")" eval '[ ! -s "$T/q.err" ] && [ -e "$T/a/q-4.png" ] && [ -e "$T/a/q-5.png" ]'

# a terminal (script(1) gives one): the bar, redrawn in place, counts the frames
if command -v script >/dev/null; then
    mkdir "$T/tty"
    (cd "$T/tty" && script -qec "'$CLIENT' job '$T/anim.json' -o 't-%d.png' --frames 3-5 --server '$URL'" \
        /dev/null </dev/null >"$T/tty.out" 2>&1)
    check progress_bar_tty "$(cat -v "$T/tty.out")" eval 'grep -q "\[##############################\] 3/3 frames .*ETA" "$T/tty.out" &&
        ! grep -q "^rayd-client: frame " "$T/tty.out" && [ "$(ls "$T/tty" | wc -l)" = 3 ]'
fi

# ---- no --frames: the whole animation; one frame takes a plain name; OpenEXR ---------------
mkdir "$T/b"
"$CLIENT" job "$T/short.json" -o "$T/b/s-%d.png" --server "$URL" 2>"$T/b.err" </dev/null
rc=$?
check whole_animation "exit $rc: $(ls "$T/b")" eval '[ "$rc" = 0 ] && [ "$(ls "$T/b" | tr "\n" " ")" = "s-2.png s-3.png s-4.png s-5.png " ]'
timeout 120 "$RENDER" "$T/short.json" --frame 5 -o "$T/short-5.png" -q
check whole_animation_bytes "s-5.png differs" cmp -s "$T/b/s-5.png" "$T/short-5.png"
"$CLIENT" job "$T/anim.json" -o "$T/one.png" --frames 4 --server "$URL" -q </dev/null
check one_frame_plain_name "exit $?" cmp -s "$T/one.png" "$T/cli-4.png"
"$CLIENT" job "$T/anim.json" -o "$T/e-%d.exr" --frames 5-6 --server "$URL" -q </dev/null
rc=$?
timeout 120 "$RENDER" "$T/anim.json" --frame 6 -o "$T/cli-6.exr" -q
check frames_exr "exit $rc" eval '[ "$rc" = 0 ] && [ -e "$T/e-5.exr" ] && cmp -s "$T/e-6.exr" "$T/cli-6.exr"'

# ---- usage errors: exit 2, nothing sent -----------------------------------------------
before=$(jobs_now)
usage() { # usage NAME TEXT ARGS...: exit 2 saying TEXT, no job made
    local name=$1 text=$2 rc
    shift 2
    "$CLIENT" "$@" --server "$URL" 2>"$T/u.err" </dev/null
    rc=$?
    check "$name" "exit $rc: $(cat "$T/u.err")" eval '[ "$rc" = 2 ] && grep -qF -- "$text" "$T/u.err" &&
        [ "$(jobs_now)" = "$before" ]'
}
usage bad_o_no_d "give -o a %d, e.g. -o 'shot-%04d.png'" job "$T/anim.json" -o "$T/x.png" --frames 3-6
usage bad_o_no_d_whole "a job of frames 2-9 writes a file a frame" job "$T/anim.json" -o "$T/x.png"
usage bad_o_two_d "takes one %d (or %0Nd, N < 10) and no other %" job "$T/anim.json" -o "$T/x-%d-%d.png"
usage bad_o_other_pct "and no other %" job "$T/anim.json" -o "$T/x-%s.png" --frames 3-4
usage bad_o_stdout "give -o a %d" job "$T/anim.json" -o - --frames 3-4
usage frames_outside "$T/anim.json: /animation: frame 12 is outside the animation's frames 2-9" job "$T/anim.json" -o "$T/x-%d.png" --frames 3-12
usage frames_still_scene "the scene has no /animation" job "$T/still.json" -o "$T/x-%d.png" --frames 0-1
usage video_still_scene "the scene has no /animation, so it has no frames to make a video" job "$T/still.json" -o "$T/x.png" --video "$T/x.mp4"
usage frames_malformed "--frames takes A-B" job "$T/anim.json" -o "$T/x-%d.png" --frames 6-3
usage frames_not_render "--frames is not an option of render (only of job)" render "$T/anim.json" -o "$T/x.png" --frames 3-4
usage video_not_mp4 "--video writes the job's H.264 MP4" job "$T/anim.json" -o "$T/x-%d.png" --video "$T/x.mkv"
usage detach_still_scene "job --detach leaves a frame range running" job "$T/still.json" -o "$T/x.png" --detach
usage detach_not_render "--detach goes with render --progressive and with job of frames" render "$T/anim.json" -o "$T/x.png" --detach
# ---- an -o or --video in a folder that is missing: exit 1 before any job is made ---------
nodir() { # NAME ARGS...
    local name=$1 rc
    shift
    "$CLIENT" job "$T/anim.json" --frames 3-4 "$@" --server "$URL" 2>"$T/nd.err" </dev/null
    rc=$?
    check "$name" "exit $rc: $(cat "$T/nd.err")" eval '[ "$rc" = 1 ] && grep -q "cannot write $T/nodir/" "$T/nd.err" &&
        [ "$(jobs_now)" = "$before" ]'
}
nodir frames_missing_folder -o "$T/nodir/x-%d.png"
nodir video_missing_folder -o "$T/x-%d.png" --video "$T/nodir/x.mp4"
# the same for a still image's job, render --progressive and render over servers
for cmd in "job" "render --progressive" "render"; do
    name=still_missing_folder_${cmd// /_}
    "$CLIENT" $cmd "$RAYD_ROOT/scenes/spheres.json" -o "$T/nodir/s.png" --server "$URL" 2>"$T/nd.err" </dev/null
    rc=$?
    check "${name//-/}" "exit $rc: $(cat "$T/nd.err")" eval '[ "$rc" = 1 ] &&
        grep -q "^rayd-client: error: cannot write $T/nodir/s.png: No such file or directory$" "$T/nd.err" &&
        [ "$(wc -l <"$T/nd.err")" = 1 ] && [ "$(jobs_now)" = "$before" ]'
done
check usage_wrote_nothing "$(ls "$T" | grep '^x')" eval '! ls "$T" | grep -q "^x"'

# ---- job --detach, then watch ID: the frames and the video as job writes them --------------
# (before, job had no --detach and watch refused a frame-range job: a client that died with its
# node, or was stopped, could not fetch a job's frames again)
mkdir "$T/w"
"$CLIENT" job "$T/anim.json" -o "$T/w/w-%d.png" --frames 3-6 --detach --server "$URL" \
    >"$T/detach.out" 2>"$T/detach.err" </dev/null
rc=$?
wid=$(cat "$T/detach.out")
check detach_frames_prints_id "exit $rc: $wid $(cat "$T/detach.err")" eval '[ "$rc" = 0 ] &&
    [[ "$wid" =~ ^[0-9a-f]{32}$ ]] && grep -q "follow it with: rayd-client watch $wid -o" "$T/detach.err" &&
    [ -z "$(ls "$T/w")" ]'
"$CLIENT" watch "$wid" --server "$URL" 2>"$T/wn.err" </dev/null
rc=$?
check watch_frames_needs_pattern "exit $rc: $(cat "$T/wn.err")" eval '[ "$rc" = 2 ] &&
    grep -q "renders frames 3-6: give -o a pattern" "$T/wn.err"'
"$CLIENT" watch "$wid" -o "$T/w/w-%d.png" --video "$T/w/w.mp4" --server "$URL" 2>"$T/w.err" </dev/null
rc=$?
n=0
for k in 3 4 5 6; do cmp -s "$T/w/w-$k.png" "$T/cli-$k.png" && n=$((n + 1)); done
check watch_frames_written "exit $rc, $n of 4 as rayd-render's: $(tail -2 "$T/w.err")" eval \
    '[ "$rc" = 0 ] && [ "$n" = 4 ] && cmp -s "$T/w/w.mp4" "$T/a/shot.mp4"'
# watching again, after the end: the same files, exit 0
rm -f "$T/w/w-4.png"
"$CLIENT" watch "$wid" -o "$T/w/w-%d.png" --server "$URL" -q 2>"$T/w2.err" </dev/null
check watch_frames_again "exit $?: $(cat "$T/w2.err")" cmp -s "$T/w/w-4.png" "$T/cli-4.png"
"$CLIENT" watch "$wid" -o "$T/w/x.png" --server "$URL" 2>"$T/w3.err" </dev/null
check watch_frames_plain_o_refused "exit $?: $(cat "$T/w3.err")" grep -q "give -o a %d" "$T/w3.err"

# ---- a failed job: exit 1, the server's error naming the frame ---------------------------
curl -s -X POST "$URL/v1/test/gate?work=10" >/dev/null # every render made now runs out of rays
"$CLIENT" job "$T/anim.json" -o "$T/f-%d.png" --frames 8-8 --server "$URL" 2>"$T/f.err" </dev/null
rc=$?
check failed_job_exit_1 "exit $rc: $(cat "$T/f.err")" eval '[ "$rc" = 1 ] &&
    grep -q "^rayd-client: error: job [0-9a-f]* failed: frame 8 failed after 3 attempts" "$T/f.err" &&
    [ ! -e "$T/f-8.png" ]'
curl -s -X POST "$URL/v1/test/gate?work=open" >/dev/null

# ---- Ctrl-C cancels the job on the server, exit 130 --------------------------------------
gate 0
"$CLIENT" job "$T/anim.json" -o "$T/c-%d.png" --server "$URL" 2>"$T/c.err" </dev/null &
cpid=$!
PIDS+=("$cpid")
wait_until 30 grep -q '^rayd-client: job [0-9a-f]* on' "$T/c.err"
idc=$(sed -n 's/^rayd-client: job \([0-9a-f]*\) on.*/\1/p' "$T/c.err")
kill -INT "$cpid"
wait "$cpid"
crc=$?
check interrupt_130 "exit $crc: $(cat "$T/c.err")" eval '[ "$crc" = 130 ] &&
    grep -q "^rayd-client: interrupted; job $idc cancelled" "$T/c.err" && ! ls "$T" | grep -q "^c-"'
check interrupt_cancels "job $idc" job_state_is "$idc" canceled
gate open

# ---- an untrusted server: absurd figures, a lie, a wrong size, escapes -------------------
cat >"$T/fake.py" <<'PY'
import http.server, json, socketserver, struct, sys, time, zlib
MODE, LOG, ID = sys.argv[1], sys.argv[2], "0123456789abcdef0123456789abcdef"
streamed = []
def png(w, h):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    data = zlib.compress(b"".join(b"\x00" + b"\x00" * (w * 3) for _ in range(h)))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", data) + chunk(b"IEND", b""))
class H(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.0"
    def log_message(self, *a):
        pass
    def send(self, status, body, ctype="application/json"):
        self.send_response(status)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)
    def do_POST(self):
        self.rfile.read(int(self.headers["Content-Length"]))
        self.send(202, json.dumps({"id": ID, "state": "queued"}).encode())
    def do_DELETE(self):
        open(LOG, "a").write("DELETE %s\n" % self.path)
        if MODE == "slow_delete":  # a busy server: the answer takes a while
            time.sleep(2.5)
        self.send(200, json.dumps({"id": ID, "state": "canceled"}).encode())
    def do_GET(self):
        open(LOG, "a").write("GET %s\n" % self.path)
        if self.path.endswith("/events") and MODE in ("stream", "wrong_size"):
            ev = "".join('event: frame\ndata: {"k": %d, "state": "done"}\n\n' % k for k in (3, 4, 5, 6, 99, -1))
            self.send(200, (ev + 'event: done\ndata: {"state": "succeeded"}\n\n').encode(), "text/event-stream")
            return streamed.append(1)
        if self.path.endswith("/events") and MODE == "one_sse":  # a one-image job's end
            ev = 'event: done\ndata: {"state": "failed", "error": "no such file", "error_path": "/objects/0/source/file"}\n\n'
            return self.send(200, ev.encode(), "text/event-stream")
        if self.path.endswith("/events"):
            return self.send(404, b'{"error":{"status":404,"code":"not_found","message":"no"}}')
        if self.path.endswith(".png") and MODE == "stream":
            return self.send(200, png(48, 32), "image/png")
        if self.path.endswith(".png") and MODE == "wrong_size":
            return self.send(200, png(8, 8), "image/png")
        if self.path.endswith(".png"):
            return self.send(409, b'{"error":{"status":409,"code":"frame_not_ready","message":"no"}}')
        if MODE.startswith("one_"):  # a one-image job whose scene failed after its POST
            return self.send(200, json.dumps({"id": ID, "state": "failed", "region": {"x": 0, "y": 0, "w": 8, "h": 8}, "error": {
                "code": "invalid_scene", "path": "/objects/0/source/file", "message": "no such file"}}).encode())
        state = "failed" if MODE in ("evil_error", "pointer") else "succeeded"
        if (MODE == "stream" and not streamed) or MODE == "slow_delete":
            state = "running"  # only the event stream says the frames are done; or never
        j = {"id": ID, "state": state, "frames": {"done": 1e300 if MODE == "lie" else 4}, "eta_s": -5,
             "error": {"code": "frame_failed", "message": "frame 3 \x1b]0;pwned\x07\x1b[2J failed"}}
        if MODE == "pointer":  # a frame's own scene error, its value named by a JSON Pointer
            j["error"] = {"code": "invalid_scene", "path": "/lights/0/keyframes",
                          "message": "frame 3 failed after 1 attempt: at frame 3, intensity: must be >= 0"}
        self.send(200, json.dumps(j).encode())
socketserver.TCPServer.allow_reuse_address = True
s = socketserver.TCPServer(("127.0.0.1", 0), H)
print(s.server_address[1], flush=True)
s.serve_forever()
PY
fake() { # fake MODE: a fake server answering in MODE; its URL in FAKE
    : >"$T/fake-$1.log"
    python3 "$T/fake.py" "$1" "$T/fake-$1.log" >"$T/fake.port" &
    PIDS+=("$!")
    FAKE_PID=$!
    wait_until 30 test -s "$T/fake.port"
    FAKE="http://127.0.0.1:$(head -1 "$T/fake.port")"
}
for mode in lie wrong_size evil_error pointer stream; do
    fake "$mode"
    mkdir "$T/u-$mode"
    timeout 60 "$CLIENT" job "$T/anim.json" -o "$T/u-$mode/h-%d.png" --frames 3-6 --server "$FAKE" \
        2>"$T/u-$mode.err" </dev/null
    echo $? >"$T/u-$mode.rc"
    kill "$FAKE_PID" && wait "$FAKE_PID" 2>/dev/null
    : >"$T/fake.port"
done
check untrusted_lie "exit $(cat "$T/u-lie.rc"): $(cat "$T/u-lie.err")" eval '[ "$(cat "$T/u-lie.rc")" = 1 ] &&
    grep -q "succeeded but serves 0 of its 4 frames (frame 3 is not done)" "$T/u-lie.err" && [ -z "$(ls "$T/u-lie")" ]'
check untrusted_wrong_size "exit $(cat "$T/u-wrong_size.rc"): $(cat "$T/u-wrong_size.err")" eval \
    '[ "$(cat "$T/u-wrong_size.rc")" = 1 ] && grep -q "is 8x8, not the 48x32 asked for" "$T/u-wrong_size.err" &&
     [ -z "$(ls "$T/u-wrong_size")" ]'
check untrusted_wrong_size_cancels "$(cat "$T/fake-wrong_size.log")" eval \
    'grep -q "^DELETE /v1/jobs/0123456789abcdef0123456789abcdef$" "$T/fake-wrong_size.log" &&
     grep -q "job 0123456789abcdef0123456789abcdef cancelled: a frame could not be written" "$T/u-wrong_size.err"'
check frames_follow_events "exit $(cat "$T/u-stream.rc"): $(cat "$T/u-stream.err")" eval \
    '[ "$(cat "$T/u-stream.rc")" = 0 ] && [ "$(ls "$T/u-stream" | tr "\n" " ")" = "h-3.png h-4.png h-5.png h-6.png " ] &&
     ! grep -q "/frames/99\|/frames/-1" "$T/fake-stream.log"'
check untrusted_escapes "exit $(cat "$T/u-evil_error.rc"): $(cat -v "$T/u-evil_error.err")" eval \
    '[ "$(cat "$T/u-evil_error.rc")" = 1 ] && grep -qF "failed: frame 3 \x1b]0;pwned\x07" "$T/u-evil_error.err" &&
     ! grep -q $'"'"'\x1b'"'"' "$T/u-evil_error.err"'
# the failed job's error names its value by the JSON Pointer, as an answer's error does
# ("HTTP 422 invalid_scene at /lights/0/keyframes: ..."); before, the message alone
check failed_job_pointer "exit $(cat "$T/u-pointer.rc"): $(cat "$T/u-pointer.err")" eval \
    '[ "$(cat "$T/u-pointer.rc")" = 1 ] && grep -qx "rayd-client: error: job 0123456789abcdef0123456789abcdef failed at /lights/0/keyframes: frame 3 failed after 1 attempt: at frame 3, intensity: must be >= 0 (0 of 4 frames written)" "$T/u-pointer.err"'
# ... and a one-image job's (rayd-client watch), whether its end comes by polling or by its
# event stream
for mode in one_poll one_sse; do
    fake "$mode"
    timeout 60 "$CLIENT" watch 0123456789abcdef0123456789abcdef -o "$T/$mode.png" --server "$FAKE" \
        2>"$T/$mode.err" </dev/null
    echo $? >"$T/$mode.rc"
    kill "$FAKE_PID" && wait "$FAKE_PID" 2>/dev/null
    : >"$T/fake.port"
done
for mode in one_poll one_sse; do
    check "${mode}_pointer" "exit $(cat "$T/$mode.rc"): $(cat "$T/$mode.err")" eval \
        "[ \"\$(cat '$T/$mode.rc')\" = 1 ] && grep -q '^rayd-client: error: job 0123456789abcdef0123456789abcdef failed at /objects/0/source/file: no such file' '$T/$mode.err'"
done

# ---- Ctrl-C delivered twice (timeout, a terminal's group): the DELETE still goes out --------
# The second signal, while the DELETE waited for its answer, used to cut it off: "may go on: its
# DELETE was not answered", and the job went on.  One a second or more later does stop it.
interrupt_twice() { # interrupt_twice NAME GAP: SIGINT, then again GAP s after the DELETE began
    fake slow_delete
    "$CLIENT" job "$T/anim.json" -o "$T/$1-%d.png" --frames 3-6 --server "$FAKE" 2>"$T/$1.err" </dev/null &
    local cpid=$!
    PIDS+=("$cpid")
    wait_until 30 grep -q '^rayd-client: job [0-9a-f]* on' "$T/$1.err"
    kill -INT "$cpid"
    wait_until 30 grep -q '^DELETE' "$T/fake-slow_delete.log"
    sleep "$2"
    kill -INT "$cpid"
    wait "$cpid"
    echo $? >"$T/$1.rc"
    kill "$FAKE_PID" && wait "$FAKE_PID" 2>/dev/null
    : >"$T/fake.port"
}
interrupt_twice twice 0.1
check interrupt_twice_cancels "exit $(cat "$T/twice.rc"): $(cat "$T/twice.err")" eval \
    '[ "$(cat "$T/twice.rc")" = 130 ] && grep -q "interrupted; job 0123456789abcdef0123456789abcdef cancelled" "$T/twice.err"'
interrupt_twice insist 1.5
check interrupt_again_stops_delete "exit $(cat "$T/insist.rc"): $(cat "$T/insist.err")" eval \
    '[ "$(cat "$T/insist.rc")" = 130 ] && grep -q "interrupted again; job 0123456789abcdef0123456789abcdef may go on: its DELETE was stopped" "$T/insist.err"'

# ---- --video from a rayd without ffmpeg: the frames, then exit 1 naming no_ffmpeg ---------
stop_rayd
mkdir -p "$T/nopath" "$T/n"
RAYD_WRAP="env PATH=$T/nopath" start_rayd --threads 1
"$CLIENT" job "$T/anim.json" -o "$T/n/n-%d.png" --frames 4-5 --video "$T/n/n.mp4" --server "$URL" \
    2>"$T/n.err" </dev/null
rc=$?
check video_no_ffmpeg "exit $rc: $(cat "$T/n.err")" eval '[ "$rc" = 1 ] && grep -q "no_ffmpeg" "$T/n.err" &&
    cmp -s "$T/n/n-4.png" "$T/cli-4.png" && [ ! -e "$T/n/n.mp4" ]'
check rayd_alive "rayd died: $(tail -3 "$T/rayd.err")" kill -0 "$RAYD_PID"

# ---- Ctrl-C while the video is made: the job had succeeded, so nothing is cancelled ------
# (an ffmpeg stand-in that waits, so the client is surely waiting for video.mp4's 202s)
stop_rayd
mkdir -p "$T/slowbin" "$T/v"
printf '#!/bin/sh\necho $$ >"%s/ffmpeg.pid"\nexec sleep 60\n' "$T" >"$T/slowbin/ffmpeg"
chmod +x "$T/slowbin/ffmpeg"
RAYD_WRAP="env PATH=$T/slowbin:$PATH" start_rayd --threads 1
"$CLIENT" job "$T/anim.json" -o "$T/v/v-%d.png" --frames 4-5 --video "$T/v/v.mp4" --server "$URL" \
    2>"$T/v.err" </dev/null &
cpid=$!
PIDS+=("$cpid")
wait_until 60 test -s "$T/ffmpeg.pid"
wait_until 30 grep -q "^rayd-client: wrote 2 frames" "$T/v.err"
idv=$(sed -n 's/^rayd-client: job \([0-9a-f]*\) on.*/\1/p' "$T/v.err")
kill -INT "$cpid"
wait "$cpid"
crc=$?
check interrupt_after_end_not_cancelled "exit $crc: $(cat "$T/v.err")" eval '[ "$crc" = 130 ] &&
    grep -q "^rayd-client: interrupted; job $idv had already succeeded$" "$T/v.err" &&
    ! grep -q "cancelled" "$T/v.err" && job_state_is "$idv" succeeded'
kill "$(cat "$T/ffmpeg.pid")" 2>/dev/null
exit $NFAIL
