#!/usr/bin/env bash
# rayd-render --passes and the HDR outputs, end to end: each pass's image
# equals the plain render of that sample count byte for byte (both
# integrators, several thread counts); EXR files are read by OpenEXR's own
# tools and library and agree with the 8-bit image; 16-bit PNGs pass
# pngcheck and agree too; bad options are named.
set -u
cd "$RAYD_ROOT"
R="$RAYD_BUILD/rayd-render"
HDR="$RAYD_BUILD/tests/tools/hdrcheck"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
ok() { echo "PASS $1"; }
bad() { echo "FAIL $1: $2"; }

# scene_with FILE SAMPLES: the scene with render.samples set.
scene_with() {
    python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); s["render"]["samples"]=int(sys.argv[2]); print(json.dumps(s))' "$1" "$2"
}

# passes_equal NAME SCENE THREADS PASS-OPTIONS...: every pass image equals
# the plain render with that many samples.
passes_equal() {
    local name=$1 scene=$2 threads=$3; shift 3
    rm -f "$T"/pass-*.png
    if ! "$R" "$scene" -o "$T/last.png" --threads "$threads" --pass-output "$T/pass-%d.png" "$@" \
        2>"$T/log"; then
        bad "$name" "exit: $(cat "$T/log")"; return
    fi
    local n all=1 count=0
    for f in "$T"/pass-*.png; do
        n=${f##*/pass-}; n=${n%.png}
        scene_with "$scene" "$n" | "$R" - -o "$T/plain.png" --threads 1
        cmp -s "$f" "$T/plain.png" || { all=0; bad "$name" "pass of $n samples differs from the plain render"; }
        count=$((count + 1))
    done
    local lines; lines=$(grep -c '^pass [0-9]*: [0-9]* samples, ' "$T/log")
    [ "$lines" = "$count" ] || { all=0; bad "$name" "$lines pass lines for $count passes"; }
    [ $all = 1 ] && [ $count -ge 3 ] && ok "$name ($count passes)"
}

passes_equal cli-passes-path-doubling tests/scenes/cornell.json 2
passes_equal cli-passes-path-step tests/scenes/cornell.json 3 --pass-step 5
passes_equal cli-passes-whitted tests/scenes/whitted.json 1
passes_equal cli-passes-whitted-step tests/scenes/whitted.json 4 --pass-step 1

"$R" tests/scenes/cornell.json -o "$T/plain.png" --threads 2
"$R" tests/scenes/cornell.json -o "$T/passes.png" --threads 1 --passes 2>/dev/null
cmp -s "$T/plain.png" "$T/passes.png" && ok cli-passes-last-equals-plain ||
    bad cli-passes-last-equals-plain "the last pass differs from the plain render"

# EXR: by extension and by --format; read by exrheader and by OpenEXR's
# C++ library (hdrcheck) and compared with the 8-bit image.
# PIZ where the floats repeat (Whitted's flat regions), none for a
# path-traced image's noise (core/codec/exr.c).
for scene in tests/scenes/cornell.json tests/scenes/whitted.json; do
    base=$(basename "$scene" .json)
    comp=piz
    [ "$base" = cornell ] && comp=none
    "$R" "$scene" -o "$T/$base.png" --threads 2
    if "$R" "$scene" -o "$T/$base.exr" --threads 2 &&
        "$R" "$scene" -o "$T/$base-f.img" --format exr --threads 1 &&
        cmp -s "$T/$base.exr" "$T/$base-f.img"; then
        ok "cli-exr-$base-deterministic"
    else
        bad "cli-exr-$base-deterministic" "EXR failed or differs between --format and .exr, threads"
    fi
    hdr=$(exrheader "$T/$base.exr" 2>&1)
    if grep -q 'R, 32-bit floating-point' <<<"$hdr" && grep -q "compression.*: $comp\$" <<<"$hdr"; then
        ok "cli-exr-$base-exrheader"
    else
        bad "cli-exr-$base-exrheader" "$hdr"
    fi
    out=$("$HDR" "$T/$base.png" "$T/$base.exr" 2>&1) && ok "cli-exr-$base-pixels ($out)" ||
        bad "cli-exr-$base-pixels" "$out"
    if "$R" "$scene" -o "$T/$base-16.png" --format png16 --threads 2 &&
        pngcheck -q "$T/$base-16.png" >/dev/null && out=$("$HDR" "$T/$base.png" "$T/$base-16.png" 2>&1); then
        ok "cli-png16-$base-pixels ($out)"
    else
        bad "cli-png16-$base-pixels" "${out:-png16 failed}"
    fi
done

# A region's EXR is the crop's size.
"$R" tests/scenes/whitted.json -o "$T/r.exr" --region 10,20,33,17 &&
    exrheader "$T/r.exr" | grep -q 'dataWindow.*(0 0) - (32 16)' && ok cli-exr-region ||
    bad cli-exr-region "$(exrheader "$T/r.exr" 2>&1 | grep dataWindow)"

# Tone: exposure 0 and clamp are today's bytes; reinhard differs.
"$R" tests/scenes/cornell.json -o "$T/t0.png" --exposure 0 --tonemap clamp --threads 2
cmp -s "$T/t0.png" "$T/plain.png" && ok cli-tone-default-identical ||
    bad cli-tone-default-identical "--exposure 0 --tonemap clamp changed the bytes"
"$R" tests/scenes/cornell.json -o "$T/t1.png" --exposure 1 --tonemap reinhard --threads 2 &&
    ! cmp -s "$T/t1.png" "$T/plain.png" && pngcheck -q "$T/t1.png" >/dev/null && ok cli-tone-reinhard ||
    bad cli-tone-reinhard "failed or unchanged"

# Bad options: exit 2, the message names the option.
expect_usage() { # name, expected text, args...
    local name=$1 want=$2; shift 2
    "$R" "$@" 2>"$T/err" >/dev/null
    local rc=$?
    if [ $rc = 2 ] && grep -q -- "$want" "$T/err"; then ok "$name"; else bad "$name" "exit $rc: $(head -1 "$T/err")"; fi
}
expect_usage cli-bad-format "--format takes png, png16 or exr, not 'jpeg'" tests/scenes/cornell.json -o "$T/x" --format jpeg
expect_usage cli-bad-tonemap "--tonemap takes clamp or reinhard, not 'aces'" tests/scenes/cornell.json -o "$T/x" --tonemap aces
expect_usage cli-bad-exposure "--exposure takes stops" tests/scenes/cornell.json -o "$T/x" --exposure 1e9
expect_usage cli-bad-pass-step "--pass-step takes an integer" tests/scenes/cornell.json -o "$T/x" --pass-step 0
expect_usage cli-bad-pass-output "--pass-output takes a file name" tests/scenes/cornell.json -o "$T/x" --pass-output "a%s"
