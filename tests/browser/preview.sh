#!/usr/bin/env bash
# preview.sh -- the browser preview (GET /) in Debian's Chromium, headless,
# against a real rayd started here on 127.0.0.1 (--port 0) and stopped by its
# PID.  preview.mjs (playwright-core from npm, installed by `make test` into
# tests/browser/node_modules) drives the page and prints PASS/FAIL lines.
# Without chromium, node or playwright-core this FAILs, never passes.
#
#   bash tests/browser/preview.sh            (tests/run.sh sets RAYD_BUILD)
#   MEASURE=1 bash tests/browser/preview.sh  also prints the timing figures
#   CASES=link bash tests/browser/preview.sh  only the cases whose names match
# rayd-test: long
source "$(dirname "$0")/../integration/lib/common.sh"
source "$(dirname "$0")/../integration/lib/browser.sh"

missing=
[ -x "$RAYD_BUILD/tests/tools/pngcmp" ] || missing="$missing $RAYD_BUILD/tests/tools/pngcmp (make test builds it)"
browser_need browser_setup "$missing"

# the page's JSON and camera helpers in Node first (no browser needed)
node "$HERE/json_unit.mjs" "$RAYD_BUILD/server/web/examples.js" || fail json_unit "node exited with $?"

# a second rayd that wants a bearer token, for the page's Token field
printf 'preview-test-token\n' >"$T/token"
start_rayd --threads 1 --token-file "$T/token"
TOKEN_URL=$URL
TOKEN_PID=$RAYD_PID
PIDS+=("$TOKEN_PID")
cp "$T/rayd.err" "$T/rayd-token.err"

# a page of another origin (another port) for framed_preview_blocked: it
# frames the preview; python's http.server on a port the kernel picks
mkdir -p "$T/framer"
python3 -m http.server 0 --bind 127.0.0.1 --directory "$T/framer" >"$T/framer.log" 2>&1 &
FRAMER_PID=$!
PIDS+=("$FRAMER_PID")
framer_listens() { [ -n "$(listen_port "$FRAMER_PID")" ]; }
wait_until 60 framer_listens || fail framer_setup "python3 -m http.server did not listen"
FRAMER_URL=http://127.0.0.1:$(listen_port "$FRAMER_PID")

# two workers, as on a small machine; the test scenes are small
start_rayd --threads 2 --test-gate open
# the screenshot is saved beside the binaries (build/preview.png)
OUT_DIR=$RAYD_BUILD PNGCMP=$RAYD_BUILD/tests/tools/pngcmp CHROMIUM=$CHROMIUM WORK=$T \
    TOKEN_URL=$TOKEN_URL TOKEN=preview-test-token FRAMER_URL=$FRAMER_URL FRAMER_DIR=$T/framer \
    timeout 600 node "$HERE/preview.mjs" "$URL"
rc=$?
[ "$rc" -eq 0 ] || fail preview_driver "node exited with status $rc"
kill "$FRAMER_PID" 2>/dev/null
wait "$FRAMER_PID" 2>/dev/null
stop_rayd
[ "$RAYD_RC" = 0 ] || fail rayd_exit "rayd exited with $RAYD_RC"
RAYD_PID=$TOKEN_PID
stop_rayd
[ "$RAYD_RC" = 0 ] || fail rayd_token_exit "rayd (token) exited with $RAYD_RC"
exit 0
