#!/usr/bin/env bash
# tests/stress.sh BUILD -- `make test-stress`: the integration tests (and the
# browser test) on a machine in two hard states, every run to pass with 0
# failed:
#   loaded   every core busy with an unrelated CPU hog (one busy loop per
#            core, started here and stopped by PID);
#   one-core the tests and every rayd they start pinned to core 0 (taskset).
# The idle state is not run here: make test is that run, and .ci/run's
# ASan run of the whole suite is another; a third would only add CI time.
# A test that depends on how long a render takes fails one of these.  Ends
# with the sum of the runs: "N passed, N failed".
#
# Left out (RAYD_SKIP): the tests of files and command lines that start no
# server or only ask one thing of it -- installing, man pages, manifests,
# the docs' examples, the bad-scene corpus, the mesh and glTF files, the
# CLIs, the fuzz replays.  Nothing in them waits on a render, and run four
# more times they would double the CI's time; make test runs them, and the
# ASan run of .ci/run again.
set -u
cd "$(dirname "$0")/.."
BUILD=${1:-build}
HOGS=()
stop_hogs() {
    local p
    for p in "${HOGS[@]}"; do kill -KILL "$p" 2>/dev/null; done
    for p in "${HOGS[@]}"; do wait "$p" 2>/dev/null; done
    HOGS=()
}
trap stop_hogs EXIT

STRESS_SKIP="install man_pages k8s_manifests docs_check cli_bad_scenes cli_gltf cli_gltf_scene cli_real_meshes
    cli_conventions cli_render cli_passes fuzz_replay simd_scalar bench_bvh asset_dir generated_files"
STRESS_SKIP=$(echo $STRESS_SKIP)
pass=0 fail=0 summary=()
run() { # name, command prefix...
    local name=$1; shift
    local log t0 line p f
    log=$(mktemp)
    t0=$(date +%s)
    echo "=== test-stress: $name"
    RAYD_ONLY=integration RAYD_SKIP="$STRESS_SKIP" "$@" bash tests/run.sh "$BUILD" >"$log" 2>&1
    line=$(tail -n 1 "$log")
    grep -E '^(--- |FAIL |failed: )' "$log" | grep -Ev ' passed \([0-9]+ s\)$'
    if [[ $line =~ ^([0-9]+)\ passed,\ ([0-9]+)\ failed$ ]]; then
        p=${BASH_REMATCH[1]} f=${BASH_REMATCH[2]}
    else
        p=0 f=1
        echo "FAIL stress_$name: no closing line: $line"
    fi
    pass=$((pass + p)) fail=$((fail + f))
    echo "slowest:"
    sed -nE 's/^--- (.*) \(([0-9]+) s\)$/\2 s  \1/p' "$log" | sort -rn | head -n 5
    summary+=("$name: $p passed, $f failed in $(($(date +%s) - t0)) s")
    echo "${summary[-1]}"
    rm -f "$log"
}

# STRESS_STATES picks the states (default "loaded one-core"); .ci/run
# keeps CI inside its time with "loaded" alone.
states=${STRESS_STATES:-loaded one-core}
if [[ " $states " == *" loaded "* ]]; then
    cores=$(nproc 2>/dev/null || echo 2)
    for _ in $(seq 1 "$cores"); do
        sh -c 'while :; do :; done' &
        HOGS+=($!)
    done
    run loaded env
    stop_hogs
fi
if [[ " $states " == *" one-core "* ]]; then
    if command -v taskset >/dev/null; then
        run one-core taskset -c 0
    else
        echo "FAIL stress_one_core: taskset missing (util-linux)"
        fail=$((fail + 1))
    fi
fi

printf '%s\n' "${summary[@]}"
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
