#!/usr/bin/env bash
# jobs_view_cluster.sh -- the preview's Jobs tab (server/web/jobs.js) against
# a cluster: a real redis-server on a free loopback port
# (tests/integration/lib/redis.sh) and two rayd nodes (--redis, --port 0,
# --test-gate, which the driver closes so a job is held for as long as a
# case needs), in Debian's Chromium, headless.  jobs_view_cluster.mjs submits a job from node A's page
# and follows it on node B's: listed, its progress from the event stream, its
# thumbnail and its PNG; then a path-traced scene on node B's page, which
# the cluster renders as a progressive job, pass by pass (and, denoised,
# refuses as one: the page posts it as a plain job).  Every process is stopped by its PID.
# Without chromium, node, playwright-core or redis-server this FAILs, never passes.
#
#   bash tests/browser/jobs_view_cluster.sh      (tests/run.sh sets RAYD_BUILD)
source "$(dirname "$0")/../integration/lib/common.sh"
source "$(dirname "$0")/../integration/lib/browser.sh"
source "$(dirname "$0")/../integration/lib/redis.sh"

browser_need jobs_cluster_browser_setup

start_redis
for i in 1 2; do
    start_node $i --threads 2 --cluster-tile 64 --redis-claim-ms 3000 --test-gate open --redis "$REDIS_URL"
done
PNGCMP=$RAYD_BUILD/tests/tools/pngcmp CHROMIUM=$CHROMIUM SCENES=$RAYD_ROOT/scenes timeout 300 node "$HERE/jobs_view_cluster.mjs" "${NODE_URL[1]}" "${NODE_URL[2]}"
rc=$?
[ "$rc" -eq 0 ] || fail jobs_cluster_driver "node exited with status $rc"
for i in 1 2; do
    kill -0 "${NODE_PID[$i]}" 2>/dev/null || fail "node_${i}_alive" "node $i died: $(tail -n 3 "$T/node$i.err")"
done
[ "$NFAIL" = 0 ]
