#!/usr/bin/env bash
# tests/run.sh BUILD -- runs every test and prints the closing line
# "N passed, N failed".
#
# Unit tests are the binaries in BUILD/tests/; integration tests are the
# scripts tests/integration/*.sh (and tests/browser/*.sh).  Every test prints
# one line per case, "PASS name" or "FAIL name: why"; this script counts them.
# A program that dies without printing FAIL counts as one failure, so a crash
# is never a pass.  The layer check (tools/check_layers.py) and the unused
# exports check (tools/unused_exports.py) run with the unit tests.  RAYD_ONLY=unit|integration limits the run;
# RAYD_TESTS="jobs lifecycle" runs only those tests/integration/NAME.sh
# (make test-tsan and make test-valgrind use it), and RAYD_UNIT="test_x"
# only those unit tests of BUILD (make test-tsan); RAYD_SKIP="a b" leaves
# those integration tests out (tests/stress.sh uses it).  SKIP lines are shown.
set -u
cd "$(dirname "$0")/.."
BUILD=$(cd "${1:-build}" && pwd)
export RAYD_BUILD="$BUILD"
export RAYD_ROOT="$PWD"
only=${RAYD_ONLY:-all}
pass=0
fail=0
failed_names=()

run_one() { # name, command...
    local name=$1; shift
    local out; out=$(mktemp)
    timeout "${RAYD_TIMEOUT:-900}" "$@" >"$out" 2>&1
    local rc=$?
    local p f
    p=$(grep -c '^PASS ' "$out")
    f=$(grep -c '^FAIL ' "$out")
    if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then
        echo "FAIL $name: exited with status $rc" >>"$out"
        f=1
    fi
    if [ "$f" -gt 0 ]; then
        echo "--- $name: $p passed, $f failed"
        grep -v '^PASS ' "$out" | tail -n 60
        failed_names+=("$name")
    else
        echo "--- $name: $p passed"
    fi
    grep '^SKIP ' "$out"
    pass=$((pass + p))
    fail=$((fail + f))
    rm -f "$out"
}

if [ -n "${RAYD_TESTS:-}" ]; then
    only=none
    for name in $RAYD_TESTS; do
        run_one "$name" bash "tests/integration/$name.sh"
    done
fi
if [ -n "${RAYD_UNIT:-}" ]; then
    only=none
    for name in $RAYD_UNIT; do
        run_one "unit/$name" "$BUILD/tests/$name"
    done
fi
if [ "$only" = all ] || [ "$only" = unit ]; then
    # The layers (docs/architecture.md): includes and calls one way down,
    # no circles; and the checker's own rules each caught when broken.
    run_one "layers" python3 tools/check_layers.py "$BUILD"
    run_one "layers self-test" python3 tools/check_layers.py --self-test
    # Every exported function has a caller in another file (or is static).
    run_one "exports" python3 tools/unused_exports.py "$BUILD"
    run_one "exports self-test" python3 tools/unused_exports.py --self-test
    for t in "$BUILD"/tests/test_*; do
        [ -x "$t" ] || continue
        run_one "unit/$(basename "$t")" "$t"
    done
fi
if [ "$only" = all ] || [ "$only" = integration ]; then
    for t in tests/integration/*.sh tests/browser/*.sh; do
        [ -f "$t" ] || continue
        [[ " ${RAYD_SKIP:-} " == *" $(basename "$t" .sh) "* ]] && continue
        run_one "$t" bash "$t"
    done
fi

[ "${#failed_names[@]}" -gt 0 ] && echo "failed: ${failed_names[*]}"
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ] && [ "$pass" -gt 0 ]
