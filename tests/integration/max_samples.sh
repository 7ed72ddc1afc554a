#!/usr/bin/env bash
# Sample counts over 1024, for reference images: the loader's limit stays
# 1024 by default (a client's scene must not buy unbounded work), and
# rayd-render --max-samples / rayd --max-samples raise it up to 65536, the
# most a pixel's exact sums can hold.  Without the option the refusal names
# /render/samples and how to raise it; with it, the image is the same bytes
# as the last pass of a progressive render of it (every sample counted) and
# the server's equals the command line's.
source "$(dirname "$0")/lib/common.sh"
R="$RAYD_BUILD/rayd-render"

cat >"$T/ref.json" <<'JSON'
{"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0]},
 "render": {"width": 4, "height": 4, "samples": 2048, "integrator": "path", "max_depth": 3},
 "materials": {"lamp": {"emission": [2, 2, 2]}},
 "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1},
             {"type": "disc", "center": [0, 2, 0], "normal": [0, -1, 0], "radius": 1, "material": "lamp"}]}
JSON

"$R" "$T/ref.json" -o "$T/no.png" -q 2>"$T/err"; rc=$?
check cli_over_1024_refused "exit $rc: $(cat "$T/err")" bash -c \
    "[ $rc = 1 ] && grep -q '/render/samples' '$T/err' && grep -q -- '--max-samples' '$T/err' && [ ! -e '$T/no.png' ]"
"$R" "$T/ref.json" -o "$T/ref.png" -q --max-samples 4096; rc=$?
"$R" "$T/ref.json" -o "$T/passes.png" -q --max-samples 2048 --pass-step 1024; rc2=$?
check cli_max_samples_renders "exit $rc / $rc2" bash -c \
    "[ $rc = 0 ] && [ $rc2 = 0 ] && cmp -s '$T/ref.png' '$T/passes.png'"
sed 's/"samples": 2048/"samples": 1024/' "$T/ref.json" >"$T/half.json"
"$R" "$T/half.json" -o "$T/half.png" -q
check cli_2048_not_1024 "the 2048-sample image equals the 1024 one" bash -c \
    "! cmp -s '$T/ref.png' '$T/half.png'"
"$R" "$T/ref.json" -o "$T/x.png" -q --max-samples 65537 2>"$T/err"; rc=$?
check cli_max_samples_bounded "exit $rc: $(cat "$T/err")" bash -c \
    "[ $rc = 2 ] && grep -q '1..65536' '$T/err'"

start_rayd --threads 1
code=$(post_json /v1/render "$T/ref.json")
check api_over_1024_refused "status $code: $(head -c 300 "$T/body")" bash -c \
    "[ $code = 413 ] && grep -q '/render/samples' '$T/body' && grep -q -- '--max-samples' '$T/body'"
stop_rayd
start_rayd --threads 1 --max-samples 2048
code=$(post_json /v1/render "$T/ref.json")
check api_max_samples_same_bytes "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/ref.png'"
sed 's/"samples": 2048/"samples": 2049/' "$T/ref.json" >"$T/over.json"
code=$(post_json /v1/render "$T/over.json")
check api_over_max_samples "status $code: $(head -c 300 "$T/body")" err_is "$T/body" 413 too_large /render/samples
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]
"$RAYD" --port 0 --max-samples 70000 >/dev/null 2>"$T/err"; rc=$?
check rayd_max_samples_bounded "exit $rc: $(cat "$T/err")" bash -c "[ $rc = 2 ] && grep -q max-samples '$T/err'"
