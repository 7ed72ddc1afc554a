#!/usr/bin/env bash
# tests/integration/lib/run_some.sh NAME... -- runs the integration scripts
# tests/integration/NAME.sh against $RAYD_BUILD (make test-tsan and make
# test-valgrind use it) and prints, like tests/run.sh, one summary line per
# script and the closing line "N passed, N failed".  A script that exits
# non-zero without a FAIL line counts as one failure.  Lives in lib/ so
# tests/run.sh does not run it as a test.
set -u
cd "$(dirname "$0")/../../.."
export RAYD_ROOT="$PWD"
export RAYD_BUILD=${RAYD_BUILD:-$PWD/build}
pass=0
fail=0
for name in "$@"; do
    out=$(mktemp)
    timeout 1800 bash "tests/integration/$name.sh" >"$out" 2>&1
    rc=$?
    p=$(grep -c '^PASS ' "$out")
    f=$(grep -c '^FAIL ' "$out")
    if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then
        echo "FAIL $name: exited with status $rc" >>"$out"
        f=1
    fi
    if [ "$f" -gt 0 ]; then
        echo "--- $name: $p passed, $f failed"
        grep -v '^PASS ' "$out" | tail -n 40
    else
        echo "--- $name: $p passed"
    fi
    grep '^SKIP ' "$out"
    pass=$((pass + p))
    fail=$((fail + f))
    rm -f "$out"
done
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ] && [ "$pass" -gt 0 ]
