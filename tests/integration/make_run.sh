#!/usr/bin/env bash
# make run as the README gives it, with its knobs: PORT (0 here: a free one,
# printed on rayd's first line), BIND, THREADS and DATA (a scratch data
# dir).  The server it starts answers, has the workers asked for, keeps its
# jobs under DATA, and a bad PORT is refused by rayd naming the option.
# make runs in a process group of its own (setsid) so that it and the rayd
# it started are stopped together, by that group's id.
# rayd-test: alone (runs make in the tree: a stale tree relinks the binaries other tests run)
source "$(dirname "$0")/lib/common.sh"
cd "$RAYD_ROOT"
BUILD_REL=$(realpath --relative-to="$RAYD_ROOT" "$RAYD_BUILD")
MAKEVARS=(BUILD="$BUILD_REL")
case $BUILD_REL in
*asan) MAKEVARS+=(SANITIZE=1) ;;
*tsan) MAKEVARS+=(TSAN=1) ;;
esac

setsid make --no-print-directory run PORT=0 BIND=127.0.0.1 THREADS=3 DATA="$T/data" \
    "${MAKEVARS[@]}" >"$T/run.out" 2>"$T/run.err" &
MAKE_PID=$!
first_line() { grep -m 1 '^rayd listening on ' "$T/run.out"; }
wait_until 120 first_line
line=$(first_line)
if ! [[ $line =~ ^rayd\ listening\ on\ http://127\.0\.0\.1:([0-9]+)$ ]]; then
    fail make_run_listens "no listening line: $(tail -n 3 "$T/run.out" "$T/run.err")"
    kill -TERM -- -"$MAKE_PID" 2>/dev/null
    wait "$MAKE_PID" 2>/dev/null
    exit 0
fi
pass make_run_listens
URL="http://127.0.0.1:${BASH_REMATCH[1]}"
code=$(curl -s -m 30 -o "$T/health" -w '%{http_code}' "$URL/readyz")
check make_run_health "status $code: $(head -c 200 "$T/health")" [ "$code" = 200 ]
threads=$(jfield "$T/health" workers)
check make_run_threads "health says $threads threads: $(head -c 300 "$T/health")" [ "$threads" = 3 ]
check make_run_data_dir "no job store under DATA: $(ls "$T/data" 2>&1)" \
    bash -c "ls '$T/data' | grep -q ."
kill -TERM -- -"$MAKE_PID" 2>/dev/null
wait "$MAKE_PID" 2>/dev/null

out=$(make --no-print-directory run PORT=eighty DATA="$T/data2" "${MAKEVARS[@]}" 2>&1)
check make_run_bad_port "make run PORT=eighty said: $(echo "$out" | tail -n 2)" \
    bash -c "echo \"\$1\" | grep -q -- '--port'" _ "$out"
