#!/usr/bin/env bash
# rayd-render end to end: regions equal crops of the full render, thread
# counts give identical bytes, stdin input, --stats, usage errors.
set -u
cd "$RAYD_ROOT"
R="$RAYD_BUILD/rayd-render"
CMP="$RAYD_BUILD/tests/tools/pngcmp"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
ok() { echo "PASS $1"; }
bad() { echo "FAIL $1: $2"; }

scene=tests/scenes/whitted.json
"$R" "$scene" -o "$T/full1.png" --threads 1 && "$R" "$scene" -o "$T/full2.png" --threads 2 &&
    "$R" "$scene" -o "$T/full7.png" --threads 7
if cmp -s "$T/full1.png" "$T/full2.png" && cmp -s "$T/full1.png" "$T/full7.png"; then
    ok cli-threads-identical-bytes
else
    bad cli-threads-identical-bytes "PNG bytes differ between 1, 2 and 7 threads"
fi

# An existing output file is written over, not emptied first: what is left
# must be the PNG alone, whether the old file was longer or shorter, both
# for a plain render (the PNG streamed from its bands) and for --passes
# (the whole PNG written at once).
head -c 3000000 /dev/urandom >"$T/over.png"
printf 'x' >"$T/short.png"
if "$R" "$scene" -o "$T/over.png" && "$R" "$scene" -o "$T/short.png" &&
    cmp -s "$T/over.png" "$T/full1.png" && cmp -s "$T/short.png" "$T/full1.png"; then
    ok cli-overwrite-existing
else
    bad cli-overwrite-existing "$(stat -c %s "$T/over.png") and $(stat -c %s "$T/short.png") bytes, want $(stat -c %s "$T/full1.png")"
fi
head -c 3000000 /dev/urandom >"$T/over-p.png"
"$R" "$scene" -o "$T/pass.png" --passes -q && "$R" "$scene" -o "$T/over-p.png" --passes -q
if cmp -s "$T/over-p.png" "$T/pass.png"; then
    ok cli-overwrite-existing-passes
else
    bad cli-overwrite-existing-passes "$(stat -c %s "$T/over-p.png") bytes, want $(stat -c %s "$T/pass.png")"
fi

all_ok=1
for region in 0,0,160,120 10,20,33,17 159,119,1,1 0,60,160,60; do
    IFS=, read -r x y w h <<<"$region"
    if ! "$R" "$scene" -o "$T/r.png" --region "$region" 2>"$T/err"; then
        bad "cli-region-$region" "exit $(cat "$T/err")"; all_ok=0; continue
    fi
    if ! "$CMP" "$T/full1.png" "$T/r.png" "$x" "$y" 2>"$T/err"; then
        bad "cli-region-$region" "$(cat "$T/err")"; all_ok=0
    fi
    # The crop PNG itself is W x H: its IHDR holds the size.
    dims=$(python3 -c "import struct,sys;d=open(sys.argv[1],'rb').read();print(*struct.unpack('>II',d[16:24]))" "$T/r.png")
    [ "$dims" = "$w $h" ] || { bad "cli-region-$region" "size $dims, want $w $h"; all_ok=0; }
done
[ $all_ok = 1 ] && ok cli-region-equals-crop

if "$R" - -o "$T/stdin.png" --threads 2 <"$scene" && cmp -s "$T/stdin.png" "$T/full1.png"; then
    ok cli-stdin
else
    bad cli-stdin "rendering from stdin differs or failed"
fi

out=$("$R" "$scene" -o "$T/s.png" --stats 2>&1)
rays=$(awk '/^rays:/ {print $2}' <<<"$out")
if [ -n "$rays" ] && [ "$rays" -ge $((160 * 120 * 4)) ] && grep -q '^rays/s: [0-9]' <<<"$out" &&
    grep -q '^wall: [0-9.]* s' <<<"$out" &&
    [ "$(grep -cE '^time (read|parse|decode|build|render|encode|write|total): [0-9.]+ s$' <<<"$out")" = 8 ]; then
    ok cli-stats
else
    bad cli-stats "unexpected --stats output: $out"
fi

# a mesh file's stages: decoding and building take time, and the stages add
# up to no more than the total
"$RAYD_BUILD/bench/genmesh" 5 "$T/m.ply" >/dev/null 2>&1
printf '{"render": {"width": 32, "height": 24}, "objects": [{"type": "mesh", "source": {"file": "m.ply"}}]}' >"$T/m.json"
out=$("$R" "$T/m.json" -o "$T/m.png" --stats 2>&1)
if python3 - "$out" <<'PY'; then ok cli-stats-mesh-stages; else bad cli-stats-mesh-stages "$out"; fi
import re, sys
t = dict(re.findall(r"^time (\w+): ([0-9.]+) s$", sys.argv[1], re.M))
t = {k: float(v) for k, v in t.items()}
parts = sum(v for k, v in t.items() if k != "total")
sys.exit(0 if t["decode"] > 0 and t["build"] > 0 and parts <= t["total"] + 1e-3 else 1)
PY

check_usage() { # name, expected stderr substring, args...
    local name=$1 want=$2; shift 2
    "$R" "$@" >"$T/out" 2>"$T/err"
    local rc=$?
    if [ $rc -eq 2 ] && grep -qF -- "$want" "$T/err"; then ok "$name"; else bad "$name" "exit $rc: $(head -c 300 "$T/err")"; fi
}
# the PNG encoder: a file pngcheck (a third-party checker) accepts, at the
# default level and every --png-level, the same pixels at each level
all_ok=1
for lv in default 0 1 6 9; do
    opt=()
    [ $lv = default ] || opt=(--png-level "$lv")
    "$R" "$scene" -o "$T/lv$lv.png" "${opt[@]}" 2>"$T/err" || { all_ok=0; bad "cli-png-level-$lv" "$(cat "$T/err")"; }
    if command -v pngcheck >/dev/null; then
        pngcheck -q "$T/lv$lv.png" >"$T/err" 2>&1 || { all_ok=0; bad "cli-pngcheck-$lv" "$(cat "$T/err")"; }
    fi
    "$CMP" "$T/full1.png" "$T/lv$lv.png" 2>"$T/err" || { all_ok=0; bad "cli-png-level-$lv-pixels" "$(cat "$T/err")"; }
done
command -v pngcheck >/dev/null || { all_ok=0; bad cli-pngcheck "pngcheck missing (make test-deps installs it)"; }
[ $all_ok = 1 ] && ok cli-png-levels-valid
s0=$(stat -c %s "$T/lv0.png") s9=$(stat -c %s "$T/lv9.png")
if [ "$s9" -lt "$s0" ]; then ok cli-png-level-honoured; else bad cli-png-level-honoured "level 9 $s9 bytes, level 0 $s0"; fi

check_usage cli-no-output "no output given" "$scene"
check_usage cli-no-scene "no scene given" -o "$T/x.png"
check_usage cli-empty-output "-o/--output needs a file name" "$scene" -o ''
check_usage cli-empty-output-frames "-o/--output needs a file name" "$scene" -o '' --frames 0-0
check_usage cli-bad-threads "--threads takes an integer" "$scene" -o "$T/x.png" --threads zero
check_usage cli-bad-region-syntax "--region takes X,Y,W,H" "$scene" -o "$T/x.png" --region 1,2,3
check_usage cli-region-outside "error: --region w: must be in 1..10" "$scene" -o "$T/x.png" --region 150,0,20,20
check_usage cli-unknown-option "rayd-render: error: unknown option '--fast'" "$scene" -o "$T/x.png" --fast
check_usage cli-bad-png-level "--png-level takes an integer in 0..9" "$scene" -o "$T/x.png" --png-level 10
if [ ! -e "$T/x.png" ]; then ok cli-no-file-on-error; else bad cli-no-file-on-error "a PNG was written"; fi

"$R" "$T/missing.json" -o "$T/x.png" 2>"$T/err"
rc=$?
if [ $rc -eq 1 ] && grep -q "cannot open" "$T/err"; then ok cli-missing-file; else bad cli-missing-file "exit $rc"; fi

"$R" "$scene" -o /nonexistent-dir/x.png 2>"$T/err"
rc=$?
if [ $rc -eq 1 ] && grep -q "cannot write" "$T/err"; then ok cli-unwritable-output; else bad cli-unwritable-output "exit $rc: $(cat "$T/err")"; fi
# said before anything is read or rendered: the scene named is not even there
"$R" "$T/missing.json" -o /nonexistent-dir/x.png --video /nonexistent-dir/x.mp4 2>"$T/err"
rc=$?
if [ $rc -eq 1 ] && [ "$(cat "$T/err")" = "rayd-render: error: cannot write /nonexistent-dir/x.png: No such file or directory" ]; then
    ok cli-unwritable-output-first
else bad cli-unwritable-output-first "exit $rc: $(cat "$T/err")"; fi
