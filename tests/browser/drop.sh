#!/usr/bin/env bash
# drop.sh -- the user's own model in the preview (server/web/model.js,
# drop.js): files opened with the Open button's file input and dropped on
# the page, in Debian's Chromium, headless, against a real rayd started here
# on 127.0.0.1 (--port 0, --max-body 2500000, stopped by its PID).  The
# models are Debian's assimp-testmodels (an OBJ, a binary PLY, a textured
# .glb, a .gltf with its .bin and texture), the environments scenes/sky.hdr
# and an EXR of tests/fuzz/corpus/envmap/.
# drop.mjs drives the page and prints PASS/FAIL lines.  Without chromium,
# node, playwright-core or the models this FAILs, never passes.
#
#   bash tests/browser/drop.sh               (tests/run.sh sets RAYD_BUILD)
#   CASES=glb bash tests/browser/drop.sh     only the cases whose names match
# rayd-test: long
source "$(dirname "$0")/../integration/lib/common.sh"
source "$(dirname "$0")/../integration/lib/browser.sh"
MODELS=${MODELS:-/usr/share/assimp/models}

missing=
[ -f "$MODELS/PLY/cube_binary.ply" ] || missing="$missing $MODELS (make test-deps installs assimp-testmodels)"
browser_need drop_setup "$missing"

start_rayd --threads 2 --max-body 2500000

# the page learns the body limit from /healthz
code=$(req GET /healthz)
max=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1])).get("max_body"))' "$T/body" 2>/dev/null)
if [ "$code" = 200 ] && [ "$max" = 2500000 ]; then pass healthz_max_body; else
    fail healthz_max_body "status $code, max_body $max: $(head -c 200 "$T/body")"; fi

CHROMIUM=$CHROMIUM MODELS=$MODELS SCENES=$RAYD_ROOT/scenes RAYD_ROOT=$RAYD_ROOT timeout 600 node "$HERE/drop.mjs" "$URL"
rc=$?
[ "$rc" -eq 0 ] || fail drop_driver "node exited with status $rc"
stop_rayd
[ "$RAYD_RC" = 0 ] || fail rayd_exit "rayd exited with $RAYD_RC"
exit 0
