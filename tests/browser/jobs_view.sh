#!/usr/bin/env bash
# jobs_view.sh -- the preview's Jobs tab (server/web/jobs.js) in Debian's
# Chromium, headless, against real rayds started here on 127.0.0.1
# (--port 0, stopped by their PIDs): one with the test gate, so a job can be
# held queued or running for as long as a case needs, and one that wants a
# bearer token (thumbnails and downloads must carry it).  jobs_view.mjs drives
# the page and prints PASS/FAIL lines; it says in each case's name which
# parts are answered by a stand-in (frame-range jobs: "stub_").
# Without chromium, node or playwright-core this FAILs, never passes.
#
#   bash tests/browser/jobs_view.sh             (tests/run.sh sets RAYD_BUILD)
#   CASES=cancel bash tests/browser/jobs_view.sh  only the cases whose names match
source "$(dirname "$0")/../integration/lib/common.sh"
source "$(dirname "$0")/../integration/lib/browser.sh"

browser_need jobs_browser_setup

printf 'jobs-test-token\n' >"$T/token"
start_rayd --threads 1 --token-file "$T/token"
TOKEN_URL=$URL
TOKEN_PID=$RAYD_PID
PIDS+=("$TOKEN_PID")

start_rayd --threads 2 --test-gate open
CHROMIUM=$CHROMIUM WORK=$T TOKEN_URL=$TOKEN_URL TOKEN=jobs-test-token SCENES=$RAYD_ROOT/scenes \
    timeout 600 node "$HERE/jobs_view.mjs" "$URL"
rc=$?
[ "$rc" -eq 0 ] || fail jobs_driver "node exited with status $rc"
stop_rayd
[ "$RAYD_RC" = 0 ] || fail rayd_exit "rayd exited with $RAYD_RC"
RAYD_PID=$TOKEN_PID
stop_rayd
[ "$RAYD_RC" = 0 ] || fail rayd_token_exit "rayd (token) exited with $RAYD_RC"
exit 0
