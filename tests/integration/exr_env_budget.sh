#!/bin/bash
# exr_env_budget.sh -- an OpenEXR environment's decoder buffers count in
# --max-memory while it decodes: two 260 KB scenes of one 4096x4096 ZIP
# tile each took 1.4 GB of RSS under a 1 GB budget before.
source "$(dirname "$0")/lib/common.sh"
start_rayd --threads 2 --parse-threads 2 --max-memory 1G
for i in 1 2; do
    python3 "$RAYD_ROOT/tests/integration/lib/exr_one_tile.py" 4096 "$T/s$i.json"
    sed -i "s/\"width\": 8/\"width\": $((7 + i))/" "$T/s$i.json"
done
cpids=()
for i in 1 2; do
    curl -s -o "$T/r$i" -H 'Content-Type: application/json' --data-binary @"$T/s$i.json" "$URL/v1/render" &
    cpids+=($!)
done
wait "${cpids[@]}"
hwm=$(awk '/VmHWM/ {print $2}' "/proc/$RAYD_PID/status")
# (a sanitizer's shadow and quarantine are memory no budget counts)
check exr_env_within_budget "peak RSS ${hwm} kB over the 1 GiB budget" \
    eval 'sanitized || [ "$hwm" -lt 1048576 ]'
for i in 1 2; do # each rendered, or refused for room now, never anything else
    check "exr_env_answer_$i" "answer $i: $(head -c 200 "$T/r$i" | tr -d '\0')" \
        eval "is_png '$T/r$i' || grep -q memory_full '$T/r$i'"
done
code=$(curl -s -o /dev/null -w '%{http_code}' -H 'Content-Type: application/json' --data-binary @"$T/s1.json" "$URL/v1/render")
check exr_env_renders "a lone EXR scene: $code" [ "$code" = 200 ]
exit $((NFAIL > 0))
