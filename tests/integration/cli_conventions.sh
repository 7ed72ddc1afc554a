#!/usr/bin/env bash
# cli_conventions.sh -- the one command-line convention of rayd, rayd-render
# and rayd-client (README: "Command-line conventions"):
#
#   - --help exits 0 and prints to stdout, ending with the exit statuses;
#   - --version prints "PROGRAM VERSION";
#   - "--opt=value" is "--opt value" (the same bytes, the same server);
#   - an unknown option exits 2 with "PROGRAM: error: ..." on stderr, a
#     runtime failure exits 1 with the same prefix (and the message keeps its
#     JSON Pointer);
#   - "-o -" writes the image to stdout, byte for byte the "-o FILE" image,
#     and nothing else goes to stdout;
#   - "--threads 0" means every core (rayd's /readyz shows the workers);
#   - rayd-render's progress line is drawn on a terminal (a pseudo-terminal
#     made by python3's pty), cleared at the end, and absent with --quiet or
#     when stderr is not a terminal.
source "$(dirname "$0")/lib/common.sh"

CLIENT=$RAYD_BUILD/rayd-client
CORES=$(getconf _NPROCESSORS_ONLN)
scene "$T/s.json" 96 64 1 spheres # 3 x 2 tiles of 32 pixels
"$RENDER" "$T/s.json" -o "$T/ref.png" --threads 2 2>"$T/ref.err" ||
    fail setup "rayd-render: $(cat "$T/ref.err")"

# run NAME PROGRAM ARGS...: stdout in $T/NAME.out, stderr in $T/NAME.err,
# the exit status in RC.
run() {
    local name=$1; shift
    timeout 120 "$@" >"$T/$name.out" 2>"$T/$name.err" </dev/null
    RC=$?
}
first_err() { head -n 1 "$T/$1.err"; }

# --- --help, --version, a bad option: the same for all three ------------------
for prog in rayd rayd-render rayd-client; do
    bin=$RAYD_BUILD/$prog
    run help "$bin" --help
    check "${prog}_help" "exit $RC, stderr '$(first_err help)'" bash -c \
        "[ $RC = 0 ] && [ ! -s '$T/help.err' ] && grep -q '^usage: $prog' '$T/help.out' &&
         tail -n 3 '$T/help.out' | tr '\\n' ' ' | grep -q 'Exit status: 0 .*2 usage error'"
    check "${prog}_help_opt_equals" "--help does not say --opt=value" \
        grep -qF "'--opt value' or '--opt=value'" "$T/help.out"
    run version "$bin" --version
    check "${prog}_version" "exit $RC: '$(cat "$T/version.out")'" bash -c \
        "[ $RC = 0 ] && [ \$(wc -l <'$T/version.out') = 1 ] && grep -Eq '^$prog [0-9][0-9A-Za-z.+~-]*\$' '$T/version.out'"
    run badopt "$bin" --no-such-option
    want="$prog: error: unknown option '--no-such-option'"
    check "${prog}_bad_option" "exit $RC, stderr '$(first_err badopt)'" bash -c \
        '[ "$1" = 2 ] && [ "$(head -n 1 "$2")" = "$3" ] && [ ! -s "$4" ]' _ \
        "$RC" "$T/badopt.err" "$want" "$T/badopt.out"
    # a prefix of two options is ambiguous, and said so with their names
    case $prog in
        rayd) amb=--max-c want_names="--max-conns, --max-conns-per-ip" ;;
        rayd-render) amb=--t want_names="--threads, --tonemap" ;;
        *) amb=--ti want_names="--tile, --timeout, --time-budget" ;;
    esac
    run ambiguous "$bin" "$amb" 1
    want="$prog: error: ambiguous option '$amb' ($want_names)"
    check "${prog}_ambiguous_option" "exit $RC, stderr '$(first_err ambiguous)'" bash -c \
        '[ "$1" = 2 ] && [ "$(head -n 1 "$2")" = "$3" ]' _ "$RC" "$T/ambiguous.err" "$want"
    run badval "$bin" --threads=many
    check "${prog}_bad_value_equals" "exit $RC, stderr '$(first_err badval)'" bash -c \
        "[ $RC = 2 ] && grep -q '^$prog: error: .*threads' '$T/badval.err'"
    run noval "$bin" --threads
    check "${prog}_missing_value" "exit $RC, stderr '$(first_err noval)'" bash -c \
        "[ $RC = 2 ] && grep -q '^$prog: error: .*threads' '$T/noval.err'"
done

# --- rayd-render --------------------------------------------------------------
run r_eq "$RENDER" "$T/s.json" --output="$T/eq.png" --threads=0 --region=0,0,64,32 --png-level=6
run r_sp "$RENDER" "$T/s.json" --output "$T/sp.png" --threads 0 --region 0,0,64,32 --png-level 6
check render_opt_equals "exit $RC, $(first_err r_eq)" bash -c \
    "[ $RC = 0 ] && [ -s '$T/eq.png' ] && cmp -s '$T/eq.png' '$T/sp.png'"
run r_t0 "$RENDER" "$T/s.json" -o "$T/t0.png" --threads 0
check render_threads_0 "exit $RC: $(first_err r_t0)" bash -c "[ $RC = 0 ] && cmp -s '$T/t0.png' '$T/ref.png'"
run r_stdout "$RENDER" "$T/s.json" -o - --threads 2
check render_stdout "exit $RC or stdout is not the -o FILE bytes" bash -c \
    "[ $RC = 0 ] && cmp -s '$T/r_stdout.out' '$T/ref.png' && [ ! -e ./- ] && [ ! -s '$T/r_stdout.err' ]"
run r_exr "$RENDER" "$T/s.json" -o - --format exr
"$RENDER" "$T/s.json" -o "$T/ref.exr" 2>/dev/null
check render_stdout_exr "exit $RC" bash -c "[ $RC = 0 ] && cmp -s '$T/r_exr.out' '$T/ref.exr'"
printf '{"objects": [{"type": "sphere", "radius": -1}]}' >"$T/bad.json"
run r_bad "$RENDER" "$T/bad.json" -o "$T/bad.png"
check render_bad_scene_exit_1 "exit $RC, stderr '$(first_err r_bad)'" bash -c \
    "[ $RC = 1 ] && [ '$(first_err r_bad)' = 'rayd-render: error: $T/bad.json: /objects/0/radius: must be > 0' ]"
printf '{"render": {"width": 8,}}' >"$T/bad2.json"
run r_bad2 "$RENDER" "$T/bad2.json" -o "$T/bad.png"
check render_bad_json_line_column "exit $RC, stderr '$(first_err r_bad2)'" bash -c \
    "[ $RC = 1 ] && grep -qx 'rayd-render: error: $T/bad2.json: line 1, column 23: malformed JSON: trailing comma before .}. is not allowed' '$T/r_bad2.err'"
# a name of a format rayd does not write is refused, not given PNG bytes;
# .EXR is OpenEXR whatever its case; --format png writes the name anyway
run r_jpg "$RENDER" "$T/s.json" -o "$T/r.jpg"
check render_refuses_jpg_name "exit $RC, stderr '$(first_err r_jpg)'" bash -c \
    "[ $RC = 2 ] && [ ! -e '$T/r.jpg' ] && grep -q '^rayd-render: error: -o .*r.jpg: rayd-render writes PNG (.png) and OpenEXR (.exr), not this format' '$T/r_jpg.err'"
run r_EXR "$RENDER" "$T/s.json" -o "$T/r.EXR"
check render_upper_exr_is_exr "exit $RC" bash -c "[ $RC = 0 ] && cmp -s '$T/r.EXR' '$T/ref.exr'"
run r_jpg_png "$RENDER" "$T/s.json" -o "$T/r2.jpg" --format png
check render_jpg_name_with_format "exit $RC" bash -c "[ $RC = 0 ] && cmp -s '$T/r2.jpg' '$T/ref.png'"
# --format against a name that names the other format rayd writes: refused
run r_exr_as_png "$RENDER" "$T/s.json" -o "$T/r3.png" --format exr
check render_exr_format_png_name_refused "exit $RC, stderr '$(first_err r_exr_as_png)'" bash -c \
    "[ $RC = 2 ] && [ ! -e '$T/r3.png' ] && grep -q 'names a PNG, but --format exr' '$T/r_exr_as_png.err'"
run r_png_as_exr "$RENDER" "$T/s.json" -o "$T/r3.Exr" --format png16
check render_png_format_exr_name_refused "exit $RC, stderr '$(first_err r_png_as_exr)'" bash -c \
    "[ $RC = 2 ] && [ ! -e '$T/r3.Exr' ] && grep -q 'names an OpenEXR file, but --format png16' '$T/r_png_as_exr.err'"
run r_write "$RENDER" "$T/s.json" -o /nonexistent-dir/x.png
check render_write_error_exit_1 "exit $RC, stderr '$(first_err r_write)'" bash -c \
    "[ $RC = 1 ] && grep -q '^rayd-render: error: cannot write /nonexistent-dir/x.png' '$T/r_write.err'"

# --- rayd: --opt=value, --threads 0 (every core), exit 1 when it cannot listen --
# same_server NAME ARGS...: a rayd with ARGS refuses a 96 x 64 scene (413
# too_large at --max-pixels 4096) and has one worker per core.
same_server() {
    local name=$1; shift
    start_rayd "$@"
    local code workers
    code=$(post_json /v1/render "$T/s.json")
    req GET /readyz >/dev/null
    workers=$(jfield "$T/body" workers)
    check "rayd_${name}" "status $code, workers $workers (cores $CORES)" \
        bash -c "[ '$code' = 413 ] && [ '$workers' = '$CORES' ]"
}
same_server opt_equals --threads=0 --max-pixels=4096
PORT_IN_USE=$PORT
run busy "$RAYD" --bind 127.0.0.1 --port "$PORT_IN_USE"
check rayd_cannot_listen_exit_1 "exit $RC, stderr '$(cat "$T/busy.err")'" bash -c \
    "[ $RC = 1 ] && grep -q '^rayd: error: cannot listen on 127.0.0.1 port $PORT_IN_USE: .*in use' '$T/busy.err' && [ \$(wc -l <'$T/busy.err') = 1 ]"
stop_rayd
same_server opt_space --threads 0 --max-pixels 4096
run badbind "$RAYD" --bind 999.1.1.1 --port 0
check rayd_bad_bind_usage_exit_2 "exit $RC, stderr '$(first_err badbind)'" bash -c \
    '[ "$1" = 2 ] && [ "$(head -n 1 "$2")" = "$3" ] && [ "$(tail -n 1 "$2")" = "$4" ]' _ "$RC" \
    "$T/badbind.err" "rayd: error: --bind must be an IPv4 or IPv6 address or localhost, not '999.1.1.1'" \
    "Try 'rayd --help'."
run badport "$RAYD" --port 70000
check rayd_bad_port_names_flag "exit $RC, stderr '$(first_err badport)'" bash -c \
    '[ "$1" = 2 ] && [ "$(head -n 1 "$2")" = "$3" ]' _ "$RC" \
    "$T/badport.err" "rayd: error: --port takes an integer in 0..65535, not '70000'"
RAYD_PORT=x run badenv "$RAYD" --port 0
check rayd_bad_env_names_variable "exit $RC, stderr '$(first_err badenv)'" bash -c \
    '[ "$1" = 2 ] && grep -q "^rayd: error: RAYD_PORT takes an integer in 0..65535, not .x.$" "$2"' _ "$RC" "$T/badenv.err"
# a value checked after the others (a word, an address, bytes) names the variable too
for bad in "RAYD_LOG_LEVEL=verbose:RAYD_LOG_LEVEL must be debug, info, warn or error, not 'verbose'" \
    "RAYD_LOG_FORMAT=yaml:RAYD_LOG_FORMAT must be text or json, not 'yaml'" \
    "RAYD_BIND=:RAYD_BIND must be an IPv4 or IPv6 address or localhost, not ''" \
    "RAYD_MAX_MEMORY=5:RAYD_MAX_MEMORY takes bytes of at least 1M"; do
    env "${bad%%:*}" "$RAYD" --port 0 >/dev/null 2>"$T/badenv2.err"
    rc=$?
    check "rayd_bad_env_names_${bad%%=*}" "exit $rc, stderr '$(head -n 1 "$T/badenv2.err")'" bash -c \
        '[ "$1" = 2 ] && grep -qF -- "rayd: error: $2" "$3"' _ "$rc" "${bad#*:}" "$T/badenv2.err"
done
stop_rayd
start_rayd --bind localhost --threads 1 # start_rayd wants 'listening on http://127.0.0.1:PORT'
code=$(req GET /healthz)
check rayd_bind_localhost "status $code" test "$code" = 200
run nofile "$RAYD" --port 0 --token-file "$T/no-such-token"
check rayd_missing_file_exit_1 "exit $RC, stderr '$(first_err nofile)'" bash -c \
    "[ $RC = 1 ] && grep -q '^rayd: error: --token-file' '$T/nofile.err'"
stop_rayd

# --- rayd-client ----------------------------------------------------------------
start_rayd --threads 2
run c_eq "$CLIENT" render "$T/s.json" --output="$T/c_eq.png" --server="$URL" --tile=32 --threads=0 -q
check client_opt_equals_and_threads_0 "exit $RC: $(first_err c_eq)" bash -c \
    "[ $RC = 0 ] && cmp -s '$T/c_eq.png' '$T/ref.png'"
run c_sp "$CLIENT" --server "$URL" render --tile 32 --threads 0 "$T/s.json" -o "$T/c_sp.png" -q
check client_opt_space_options_first "exit $RC: $(first_err c_sp)" bash -c \
    "[ $RC = 0 ] && cmp -s '$T/c_sp.png' '$T/ref.png'"
run c_out "$CLIENT" render "$T/s.json" -o - --server "$URL" --tile 32
check client_stdout "exit $RC or stdout is not the image" bash -c \
    "[ $RC = 0 ] && cmp -s '$T/c_out.out' '$T/ref.png' && [ ! -e ./- ] && grep -q '^rayd-client: wrote standard output' '$T/c_out.err'"
run c_job "$CLIENT" job "$T/s.json" -o - --server "$URL"
check client_job_stdout "exit $RC: $(first_err c_job)" bash -c "[ $RC = 0 ] && cmp -s '$T/c_job.out' '$T/ref.png'"
run c_bad "$CLIENT" render "$T/bad.json" -o "$T/c_bad.png" --server "$URL"
check client_bad_scene_exit_1 "exit $RC, stderr '$(first_err c_bad)'" bash -c \
    "[ $RC = 1 ] && grep -q '^rayd-client: error: .*/objects/0/radius: must be > 0' '$T/c_bad.err' && [ ! -e '$T/c_bad.png' ]"
# An OpenEXR comes only from summed sample ranges or a job (?format=exr):
# tiles are 8-bit PNGs, which must not be written under an .exr name.
run c_exr_render "$CLIENT" render "$T/s.json" -o "$T/c_render.exr" --server "$URL" -q
check client_render_exr_needs_split_samples "exit $RC, stderr '$(first_err c_exr_render)'" bash -c \
    "[ $RC = 2 ] && grep -q '^rayd-client: error: -o .*c_render.exr: OpenEXR comes only from render --split-samples N or from job' '$T/c_exr_render.err' && [ ! -e '$T/c_render.exr' ]"
"$RENDER" "$T/s.json" -o "$T/ref.exr" --threads 1
run c_exr_job "$CLIENT" job "$T/s.json" -o "$T/c_job.exr" --server "$URL" -q
check client_job_writes_exr "exit $RC: $(first_err c_exr_job)" bash -c \
    "[ $RC = 0 ] && cmp -s '$T/c_job.exr' '$T/ref.exr'"
# --split-samples's progress counts sample ranges, not tiles (1 here: the scene has 1 sample)
run c_split_words "$CLIENT" render "$T/s.json" -o "$T/c_split_words.png" --server "$URL" --split-samples 2
check client_split_progress_says_ranges "exit $RC: $(tail -n 2 "$T/c_split_words.err")" bash -c \
    "[ $RC = 0 ] && grep -q '/1 sample ranges (100%)' '$T/c_split_words.err' && ! grep -q 'tiles' '$T/c_split_words.err'"
run c_exr_split "$CLIENT" render "$T/s.json" -o "$T/c_split.exr" --server "$URL" --split-samples 1 -q
check client_split_samples_writes_exr "exit $RC: $(first_err c_exr_split)" bash -c \
    "[ $RC = 0 ] && [ \"\$(head -c 4 '$T/c_split.exr' | od -An -tx1 | tr -d ' ')\" = 762f3101 ]"
run c_webp "$CLIENT" render "$T/s.json" -o "$T/c.webp" --server "$URL"
check client_refuses_webp_name "exit $RC, stderr '$(first_err c_webp)'" bash -c \
    "[ $RC = 2 ] && [ ! -e '$T/c.webp' ] && grep -q '^rayd-client: error: -o .*c.webp: rayd-client writes PNG (.png) and OpenEXR (.exr), not this format' '$T/c_webp.err'"
# --tile and --split-samples are alternatives (a range is the whole image):
# both at once is a usage error in one line and the Try line, not a --tile
# dropped unsaid.
run c_tile_split "$CLIENT" render "$T/s.json" -o "$T/c_tile_split.png" --server "$URL" --tile 64 --split-samples 2
check client_tile_with_split_samples_usage "exit $RC, stderr '$(cat "$T/c_tile_split.err")'" bash -c \
    '[ "$1" = 2 ] && [ "$(wc -l <"$2")" = 2 ] && [ "$(tail -n 1 "$2")" = "$3" ] && [ ! -e "$4" ] &&
     head -n 1 "$2" | grep -q "^rayd-client: error: --tile and --split-samples exclude each other"' _ \
    "$RC" "$T/c_tile_split.err" "Try 'rayd-client --help'." "$T/c_tile_split.png"
# an option the command would drop unsaid is a usage error
for c in "job:--tile 64:--tile is not an option of job (only of render and thumbnails)" \
    "job:--retries 1:--retries is not an option of job (only of render and thumbnails)" \
    "render:--size 64:--size is not an option of render (only of thumbnails)"; do
    IFS=: read -r cmd opt want <<<"$c"
    run c_not_for "$CLIENT" "$cmd" "$T/s.json" -o "$T/c_not_for.png" --server "$URL" $opt
    check "client_${cmd}_refuses_${opt%% *}" "exit $RC, stderr '$(first_err c_not_for)'" bash -c \
        '[ "$1" = 2 ] && [ "$(head -n 1 "$2")" = "rayd-client: error: $3" ] && [ ! -e "$4" ]' _ \
        "$RC" "$T/c_not_for.err" "$want" "$T/c_not_for.png"
done
stop_rayd
run c_down "$CLIENT" render "$T/s.json" -o "$T/c_down.png" --server "http://127.0.0.1:$PORT" --retries 0 -q
check client_unreachable_exit_1 "exit $RC, stderr '$(first_err c_down)'" bash -c \
    "[ $RC = 1 ] && grep -q '^rayd-client: error: incomplete image' '$T/c_down.err' && [ ! -e '$T/c_down.png' ]"
# One failure, one error line: the missing tiles and the last error share
# it, the error (the cause) before the list of tiles; a server whose --max-work refuses the frame answers every range (or
# every tile, to every address) with the same 413, which is said once.
check client_unreachable_one_line "$(cat "$T/c_down.err")" bash -c \
    "[ \$(wc -l <'$T/c_down.err') = 1 ] && grep -q 'tiles missing; last error: [^;]*onnect[^;]*; missing: x=' '$T/c_down.err'"
scene "$T/s4.json" 96 64 4 spheres
start_rayd --threads 1 --max-work 1000
for how in ranges tiles; do
    args=(--split-samples 4)
    [ $how = tiles ] && args=(--tile 32 --server "$URL/")
    run "c_413_$how" "$CLIENT" render "$T/s4.json" -o "$T/c_413.png" --server "$URL" "${args[@]}" -q
    check "client_refused_one_line_$how" "exit $RC, stderr: $(cat "$T/c_413_$how.err")" bash -c \
        "[ $RC = 1 ] && [ \$(wc -l <'$T/c_413_$how.err') = 1 ] && [ ! -e '$T/c_413.png' ] &&
         grep -q '^rayd-client: error: $URL/* refused the scene: HTTP 413 over_budget' '$T/c_413_$how.err'"
done
stop_rayd
# The same, whatever the timing: a server that answers the 4 ranges only
# when all 4 have come, and writes the four 413s while the client is
# stopped (SIGSTOP), so that it reads them at once.
cat >"$T/refuse_all.py" <<'EOF'
import os, signal, socket, sys, time
port_file, pid_file, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
srv = socket.create_server(("127.0.0.1", 0))
open(port_file, "w").write(str(srv.getsockname()[1]))
def read_request(c):  # the head, then Content-Length bytes of body
    data = b""
    while b"\r\n\r\n" not in data:
        data += c.recv(65536)
    head, _, body = data.partition(b"\r\n\r\n")
    size = [int(l.split(b":")[1]) for l in head.split(b"\r\n") if l.lower().startswith(b"content-length:")]
    while len(body) < (size[0] if size else 0):
        body += c.recv(65536)
conns = []
for _ in range(n):
    c, _ = srv.accept()
    read_request(c)
    conns.append(c)
while not open(pid_file).read().strip():
    time.sleep(0.01)
pid = int(open(pid_file).read())
os.kill(pid, signal.SIGSTOP)
try:
    while open("/proc/%d/stat" % pid).read().rsplit(")", 1)[1].split()[0] != "T":
        time.sleep(0.01)
    msg = b'{"error": {"status": 413, "code": "over_budget", "message": "over the budget"}}'
    for c in conns:
        c.sendall(b"HTTP/1.1 413 Payload Too Large\r\nContent-Type: application/json\r\n"
                  b"Content-Length: %d\r\n\r\n%s" % (len(msg), msg))
finally:
    os.kill(pid, signal.SIGCONT)
for c in conns:
    c.recv(1)  # until the client hangs up
EOF
: >"$T/refuse.pid"
python3 "$T/refuse_all.py" "$T/refuse.port" "$T/refuse.pid" 4 &
PIDS+=("$!")
wait_until 20 test -s "$T/refuse.port"
"$CLIENT" render "$T/s4.json" -o "$T/c_413.png" --server "http://127.0.0.1:$(cat "$T/refuse.port")" \
    --split-samples 4 --timeout 60 -q 2>"$T/c_413_at_once.err" </dev/null &
echo $! >"$T/refuse.pid" # the client's own PID, which the server stops
wait $!
RC=$?
check client_refused_one_line_at_once "exit $RC, stderr: $(cat "$T/c_413_at_once.err")" bash -c \
    "[ $RC = 1 ] && [ \$(wc -l <'$T/c_413_at_once.err') = 1 ] &&
     grep -q '^rayd-client: error: .* refused the scene: HTTP 413 over_budget: over the budget\$' '$T/c_413_at_once.err'"
run c_nocmd "$CLIENT"
check client_no_command_exit_2 "exit $RC, stderr '$(first_err c_nocmd)'" bash -c \
    "[ $RC = 2 ] && [ '$(first_err c_nocmd)' = 'rayd-client: error: no command given (render, job, watch, health or thumbnails)' ]"
run c_ftp "$CLIENT" render "$T/s.json" -o "$T/c_ftp.png" --server ftp://127.0.0.1
check client_server_not_http_exit_2 "exit $RC, stderr '$(first_err c_ftp)'" bash -c \
    "[ $RC = 2 ] && grep -q '^rayd-client: error: --server wants an http:// or https:// URL' '$T/c_ftp.err' && tail -n 1 '$T/c_ftp.err' | grep -q '^Try '"
# rayd-curl.sh names a scene it cannot read (curl alone would send an empty
# body, and the server's answer would be about JSON, not the file).
run curl_nofile sh "$RAYD_ROOT/programs/curl/rayd-curl.sh" "$T/no-such.json" "$T/curl.png" "http://127.0.0.1:$PORT"
check rayd_curl_unreadable_scene "exit $RC, stderr '$(first_err curl_nofile)'" bash -c \
    "[ $RC = 1 ] && [ '$(first_err curl_nofile)' = 'rayd-curl: error: cannot read $T/no-such.json' ] && [ ! -e '$T/curl.png' ] && [ ! -e '$T/curl.png.part' ]"
# ... and a server that does not answer, with curl's reason (not "HTTP 000:")
run curl_noserver sh "$RAYD_ROOT/programs/curl/rayd-curl.sh" scenes/paper.json "$T/curl.png" "http://127.0.0.1:1"
check rayd_curl_no_answer "exit $RC, stderr '$(first_err curl_noserver)'" bash -c \
    "[ $RC = 1 ] && grep -q '^rayd-curl: error: no answer from http://127.0.0.1:1: curl: (7)' '$T/curl_noserver.err' && [ ! -e '$T/curl.png' ] && [ ! -e '$T/curl.png.part' ] && [ ! -e '$T/curl.png.part.err' ]"

# --- rayd-render's progress line ---------------------------------------------------
# on_tty NAME ARGS...: runs rayd-render with stdin, stdout and stderr on a
# pseudo-terminal; what the terminal received in $T/NAME.tty, exit in RC.
on_tty() {
    local name=$1; shift
    python3 - "$T/$name.tty" "$RENDER" "$@" <<'PY'
import os, pty, subprocess, sys
out, argv = sys.argv[1], sys.argv[2:]
master, slave = pty.openpty()
p = subprocess.Popen(argv, stdin=slave, stdout=slave, stderr=slave, close_fds=True)
os.close(slave)
data = b""
while True:
    try:
        chunk = os.read(master, 65536)
    except OSError:  # EIO: every writer closed the terminal
        break
    if not chunk:
        break
    data += chunk
open(out, "wb").write(data)
sys.exit(p.wait())
PY
    RC=$?
}
# A progress line "  N%  D/T tiles  S s[  eta E s]", then cleared: the
# terminal's last bytes are a carriage return, spaces and a carriage return.
progress_ok() {
    python3 - "$1" "$2" <<'PY'
import re, sys
d = open(sys.argv[1], "rb").read().decode()
tiles = sys.argv[2]
lines = re.findall(r"\r  +\d+%(?:  pass \d+/\d+)?  \d+/" + tiles + r" tiles  [0-9.]+ s", d)
sys.exit(0 if lines and re.search(r"\r +\r$", d) else 1)
PY
}
on_tty tty "$T/s.json" -o "$T/tty.png" --threads 2
check progress_on_tty "exit $RC" bash -c "[ $RC = 0 ] && cmp -s '$T/tty.png' '$T/ref.png'"
check progress_line_drawn_and_cleared "terminal got: $(tr '\r' '|' <"$T/tty.tty" | head -c 300)" \
    progress_ok "$T/tty.tty" 6
on_tty ttyq "$T/s.json" -o "$T/ttyq.png" --threads 2 --quiet
check progress_quiet "exit $RC, terminal got: $(tr '\r' '|' <"$T/ttyq.tty" | head -c 200)" bash -c \
    "[ $RC = 0 ] && [ ! -s '$T/ttyq.tty' ] && cmp -s '$T/ttyq.png' '$T/ref.png'"
run notty "$RENDER" "$T/s.json" -o "$T/notty.png" --threads 2
check progress_not_on_a_pipe "exit $RC, stderr: $(tr '\r' '|' <"$T/notty.err" | head -c 200)" bash -c \
    "[ $RC = 0 ] && [ ! -s '$T/notty.err' ]"
# With passes, each pass line starts on a cleared line.
on_tty ttyp "$T/s.json" -o "$T/ttyp.png" --threads 2 --pass-step 1
check progress_with_passes "exit $RC, terminal got: $(tr '\r' '|' <"$T/ttyp.tty" | head -c 300)" bash -c \
    "[ $RC = 0 ] && grep -q 'pass 1/1' '$T/ttyp.tty' && grep -aq \$'\r *\rpass 1: 1 samples' '$T/ttyp.tty'"
on_tty ttyo "$T/s.json" -o -
check render_refuses_terminal_stdout "exit $RC, terminal got: $(head -c 200 "$T/ttyo.tty")" bash -c \
    "[ $RC = 2 ] && grep -aq 'rayd-render: error: -o - writes the image to standard output, which is a terminal' '$T/ttyo.tty'"
exit 0
