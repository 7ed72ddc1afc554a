#!/usr/bin/env bash
# docs_check.sh -- the examples marked <!-- docs-check --> in README.md and
# docs/*.md, run against this build and a rayd of its own
# (tools/docs_check.py): one PASS/FAIL line per example, named FILE:LINE.
set -u
cd "$(dirname "$0")/../.."
exec python3 tools/docs_check.py "${RAYD_BUILD:-build}" README.md docs/*.md
