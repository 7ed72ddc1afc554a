#!/usr/bin/env bash
# Replays every fuzz seed and every saved crash through its target (built
# without libFuzzer by `make test`): each must run to the end under the
# build's sanitizers.
set -u
cd "$RAYD_ROOT"
for dir in tests/fuzz/corpus/* tests/fuzz/regressions/*; do
    target=$(basename "$dir")
    bin="$RAYD_BUILD/tests/fuzz/replay_$target"
    [ -x "$bin" ] || { echo "FAIL replay-$target: $bin not built"; continue; }
    files=("$dir"/*)
    [ -e "${files[0]}" ] || continue
    "$bin" "${files[@]}" 2>&1 | sed "s|^PASS replay |PASS replay-$target |; s|^FAIL replay |FAIL replay-$target |"
    rc=${PIPESTATUS[0]}
    [ "$rc" -eq 0 ] || echo "FAIL replay-$target: exited with $rc"
done
