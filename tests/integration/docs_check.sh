#!/usr/bin/env bash
# docs_check.sh -- every command block of README.md and docs/*.md pasted in
# order, one shell per page, into a fresh copy of the repository (the files
# git tracks, this build linked in) with a rayd started as `make run` starts
# it; marked examples also compared with what the page shows
# (tools/docs_check.py, tools/docs_paste.py).  First the checker's own
# self-test: each of its rules must fail a block that breaks it.  One
# PASS/FAIL/SKIP line per block, named FILE:LINE.
set -u
cd "$(dirname "$0")/../.."
B=${RAYD_BUILD:-build}
st=0
python3 tools/docs_check.py "$B" --self-test || st=1
python3 tools/docs_check.py "$B" README.md docs/*.md || st=1
exit $st
