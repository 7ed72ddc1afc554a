#!/usr/bin/env bash
# tests/run.sh BUILD -- runs every test and prints the closing line
# "N passed, N failed".
#
# Unit tests are the binaries in BUILD/tests/; integration tests are the
# scripts tests/integration/*.sh (and tests/browser/*.sh).  Every test prints
# one line per case, "PASS name" or "FAIL name: why"; this script counts them.
# A program that dies without printing FAIL counts as one failure, so a crash
# is never a pass.  The layer, tree and unused-export checks
# (tools/check_layers.py, tools/check_tree.py, tools/unused_exports.py) run
# with the unit tests.  RAYD_ONLY=unit|integration limits the run;
# RAYD_TESTS="jobs lifecycle" runs only those tests/integration/NAME.sh
# (make test-tsan and make test-valgrind use it), and RAYD_UNIT="test_x"
# only those unit tests of BUILD (make test-tsan); RAYD_SKIP="a b" leaves
# those integration tests out (tests/stress.sh uses it).  SKIP lines are shown,
# and each test's line ends with the seconds it took, to find the slow ones.
# RAYD_JOBS=N runs up to N tests at once (default 2, 1 on one core): each
# integration test starts its own rayd on its own port and folder, so they
# do not meet; their reports are printed whole, in the order they end.  A
# test whose file has the line "# rayd-test: alone" (a reason may follow)
# runs with none beside it (it measures its rayd's resident memory against
# an idle figure, loads every core itself, or runs make in the tree, which
# relinks the binaries the other tests run when a source changed since the
# build): those run first, one by one.  "# rayd-test: long"
# marks the longest, started before the others so that none is left
# running by itself at the end.
set -u
cd "$(dirname "$0")/.."
BUILD=$(cd "${1:-build}" && pwd)
export RAYD_BUILD="$BUILD"
export RAYD_ROOT="$PWD"
only=${RAYD_ONLY:-all}
# python3 resolved once, to the interpreter it runs: a version manager's
# shim (pyenv's) is a chain of bash scripts at every call, 0.8 s of CPU
# against 0.09 s for the interpreter itself, and the tests call python3
# thousands of times.  The same interpreter, so the same modules.
pybin=$(mktemp -d)
trap 'rm -rf "$pybin"' EXIT
py=$(python3 -c 'import sys; print(sys.executable)' 2>/dev/null)
if [ -n "$py" ] && [ -x "$py" ] && [ "$py" != "$(command -v python3)" ]; then
    ln -s "$py" "$pybin/python3"
    export PATH="$pybin:$PATH"
fi
pass=0
fail=0
failed_names=()

run_one() { # name, command...
    local name=$1; shift
    local out; out=$(mktemp)
    local t0=$SECONDS
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
        echo "--- $name: $p passed, $f failed ($((SECONDS - t0)) s)"
        grep -v '^PASS ' "$out" | tail -n 60
        failed_names+=("$name")
    else
        echo "--- $name: $p passed ($((SECONDS - t0)) s)"
    fi
    grep '^SKIP ' "$out"
    pass=$((pass + p))
    fail=$((fail + f))
    rm -f "$out"
}

# Parallel integration tests: each runs run_one in a subshell whose report
# and counts go to files in $par, gathered as they end.
jobs_max=${RAYD_JOBS:-$(($(nproc 2>/dev/null || echo 1) > 1 ? 2 : 1))}
par=$(mktemp -d)
trap 'rm -rf "$par" "$pybin"' EXIT
started=0
gathered=0
gather() { # prints and counts every finished report not yet gathered
    local f n p x names
    for f in "$par"/*.done; do
        [ -e "$f" ] || continue
        n=${f%.done}
        cat "$n.log"
        read -r p x names <"$n.sum"
        pass=$((pass + p))
        fail=$((fail + x))
        [ -n "$names" ] && failed_names+=($names)
        rm -f "$f" "$n.log" "$n.sum"
        gathered=$((gathered + 1))
    done
}
run_test() { # name, command...
    if [ "$jobs_max" -le 1 ]; then
        run_one "$@"
        return
    fi
    while [ "$(jobs -rp | wc -l)" -ge "$jobs_max" ]; do
        wait -n
        gather
    done
    started=$((started + 1))
    local key; key=$par/$(printf '%04d' "$started")
    (
        pass=0 fail=0 failed_names=()
        run_one "$@" >"$key.log"
        echo "$pass $fail ${failed_names[*]}" >"$key.sum"
        touch "$key.done"
    ) &
}
finish_tests() {
    while [ "$gathered" -lt "$started" ]; do
        wait -n 2>/dev/null || sleep 0.2
        gather
    done
}

# mark FILE: the word of its "# rayd-test: WORD" line (alone, long), if any
mark() { sed -n 's/^# rayd-test: \([a-z]*\).*/\1/p' "$1" | head -n 1; }
# run_scripts FILE...: the alone ones first, one by one, then the long ones
# and the rest, RAYD_JOBS at a time
run_scripts() {
    local t alone=() long=() rest=()
    for t in "$@"; do
        case $(mark "$t") in
        alone) alone+=("$t") ;;
        long) long+=("$t") ;;
        *) rest+=("$t") ;;
        esac
    done
    for t in "${alone[@]}"; do
        run_one "$t" bash "$t"
    done
    for t in "${long[@]}" "${rest[@]}"; do
        run_test "$t" bash "$t"
    done
    finish_tests
}

if [ -n "${RAYD_TESTS:-}" ]; then
    only=none
    scripts=()
    for name in $RAYD_TESTS; do
        scripts+=("tests/integration/$name.sh")
    done
    run_scripts "${scripts[@]}"
fi
if [ -n "${RAYD_UNIT:-}" ]; then
    only=none
    for name in $RAYD_UNIT; do
        run_test "unit/$name" "$BUILD/tests/$name"
    done
    finish_tests
fi
if [ "$only" = all ] || [ "$only" = unit ]; then
    # The layers (docs/architecture.md): includes and calls one way down,
    # no circles; and the checker's own rules each caught when broken.
    run_test "layers" python3 tools/check_layers.py "$BUILD"
    run_test "layers self-test" python3 tools/check_layers.py --self-test
    # docs/architecture.md names only what exists and describes every
    # folder; no source file over 1,000 lines (tools/check_tree.py).
    run_test "tree" python3 tools/check_tree.py
    run_test "tree self-test" python3 tools/check_tree.py --self-test
    # Every link between the pages (README.md, docs/ ...) finds its file
    # and anchor (tools/check_links.py).
    run_test "links" python3 tools/check_links.py
    run_test "links self-test" python3 tools/check_links.py --self-test
    # Every exported function has a caller in another file (or is static).
    run_test "exports" python3 tools/unused_exports.py "$BUILD"
    run_test "exports self-test" python3 tools/unused_exports.py --self-test
    for t in "$BUILD"/tests/test_*; do
        [ -x "$t" ] || continue
        run_test "unit/$(basename "$t")" "$t"
    done
    finish_tests
fi
if [ "$only" = all ] || [ "$only" = integration ]; then
    scripts=()
    for t in tests/integration/*.sh tests/browser/*.sh; do
        [ -f "$t" ] || continue
        [[ " ${RAYD_SKIP:-} " == *" $(basename "$t" .sh) "* ]] && continue
        scripts+=("$t")
    done
    run_scripts "${scripts[@]}"
fi

[ "${#failed_names[@]}" -gt 0 ] && echo "failed: ${failed_names[*]}"
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ] && [ "$pass" -gt 0 ]
