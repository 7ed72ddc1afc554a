#!/usr/bin/env bash
# bench/latency.sh BUILD -- issue 19's figures: p50/p99 latency of 64x64
# tile renders on an idle server and beside a backlog of path-traced bulk
# jobs, and the bulk throughput lost to fair scheduling (bench/latency.py).
# Run by bench/run.sh (`make bench`); RUNS (default 3) runs, medians.
set -eu
cd "$(dirname "$0")/.."
python3 bench/latency.py "${1:-build}/rayd" "${RUNS:-3}"
