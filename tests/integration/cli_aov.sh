#!/usr/bin/env bash
# rayd-render --aov and --alpha, end to end: the AOV files beside a PNG,
# the EXR's channels read by OpenEXR's own exrheader, the same bytes for
# any thread count and for passes, the scene's render.aov as the default,
# and every bad value refused with a usage error naming it.
set -u
cd "$RAYD_ROOT"
R="$RAYD_BUILD/rayd-render"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
ok() { echo "PASS $1"; }
bad() { echo "FAIL $1: $2"; }

S=tests/scenes/whitted.json
names="albedo normal depth alpha object material"

# The files, named after -o, each a PNG of the image's size.
if "$R" "$S" -o "$T/a.png" --aov albedo,normal,depth,alpha,id --threads 1 -q 2>"$T/log"; then
    all=1
    for n in $names; do
        f="$T/a.$n.png"
        [ -s "$f" ] && file "$f" | grep -q 'PNG image data' || { all=0; bad cli-aov-files "no $f"; }
    done
    [ $all = 1 ] && ok cli-aov-files
else
    bad cli-aov-files "exit: $(cat "$T/log")"
fi

# The beauty is the plain render's, whatever the AOVs.
"$R" "$S" -o "$T/plain.png" --threads 2 -q
cmp -s "$T/a.png" "$T/plain.png" && ok cli-aov-beauty-unchanged ||
    bad cli-aov-beauty-unchanged "the image differs from the plain render"

# Threads and passes change no byte of any AOV file.
"$R" "$S" -o "$T/b.png" --aov all --threads 3 -q
"$R" "$S" -o "$T/c.png" --aov all --threads 2 --passes --pass-step 1 -q 2>/dev/null
same=1
for n in $names; do
    cmp -s "$T/a.$n.png" "$T/b.$n.png" || { same=0; bad cli-aov-threads "$n differs on 3 threads"; }
    cmp -s "$T/a.$n.png" "$T/c.$n.png" || { same=0; bad cli-aov-passes "$n differs after passes"; }
done
[ $same = 1 ] && ok cli-aov-threads-and-passes

# A region's AOVs are the crop of the whole's.
P="$RAYD_BUILD/tests/tools/pngcmp"
"$R" "$S" -o "$T/crop.png" --aov all --region 50,30,70,41 --threads 1 -q
same=1
for n in $names; do
    "$P" "$T/a.$n.png" "$T/crop.$n.png" 50 30 2>>"$T/cmp" || { same=0; bad cli-aov-region-crop "$n: $(cat "$T/cmp")"; }
done
[ $same = 1 ] && ok cli-aov-region-crop
"$R" "$S" -o "$T/full.exr" --aov all --threads 2 -q

# The EXR's channels, as compositors name them.
if exrheader "$T/full.exr" >"$T/hdr" 2>&1; then
    all=1
    for c in R G B albedo.R albedo.G albedo.B N.X N.Y N.Z Z A objectId materialId; do
        grep -q "^    $c, 32-bit floating-point" "$T/hdr" || { all=0; bad cli-aov-exr-channels "no $c"; }
    done
    [ "$(grep -c ', 32-bit floating-point' "$T/hdr")" = 13 ] || { all=0; bad cli-aov-exr-channels "not 13 channels"; }
    [ $all = 1 ] && ok cli-aov-exr-channels
else
    bad cli-aov-exr-channels "exrheader: $(cat "$T/hdr")"
fi
"$R" "$S" -o "$T/plain.exr" --threads 2 -q
[ "$(exrheader "$T/plain.exr" | grep -c ', 32-bit floating-point')" = 3 ] && ok cli-exr-without-aov ||
    bad cli-exr-without-aov "an EXR without --aov has other channels than R, G, B"

# --alpha: an RGBA PNG; the scene's sky is transparent, its floor opaque.
"$R" "$S" -o "$T/rgba.png" --alpha --threads 2 -q
if file "$T/rgba.png" | grep -q 'RGBA'; then ok cli-alpha-rgba; else bad cli-alpha-rgba "$(file "$T/rgba.png")"; fi
python3 - "$T/rgba.png" <<'PY' && ok cli-alpha-values || bad cli-alpha-values "alpha not 0 on the sky and 255 on the floor"
import struct, sys, zlib
data = open(sys.argv[1], "rb").read()
pos, idat, w, h = 8, b"", 0, 0
while pos < len(data):
    n, kind = struct.unpack(">I4s", data[pos:pos + 8])
    body = data[pos + 8:pos + 8 + n]
    if kind == b"IHDR": w, h = struct.unpack(">II", body[:8])
    if kind == b"IDAT": idat += body
    pos += 12 + n
raw, stride, rows, prev = zlib.decompress(idat), w * 4, [], bytearray(w * 4)
for y in range(h):
    f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
    for i in range(stride):
        a = line[i - 4] if i >= 4 else 0
        b, c = prev[i], prev[i - 4] if i >= 4 else 0
        p = a + b - c
        pr = a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else b if abs(p - b) <= abs(p - c) else c
        line[i] = (line[i] + [0, a, b, (a + b) // 2, pr][f]) & 255
    rows.append(line)
    prev = line
sys.exit(0 if rows[0][3] == 0 and rows[h - 1][3] == 255 else 1)
PY

# The scene's render.aov is the default; --aov none turns it off.
python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); s["render"]["aov"]=["depth"]; print(json.dumps(s))' "$S" >"$T/scene.json"
"$R" "$T/scene.json" -o "$T/s.png" --threads 2 -q
"$R" "$T/scene.json" -o "$T/n.png" --aov none --threads 2 -q
if [ -s "$T/s.depth.png" ] && [ ! -e "$T/s.albedo.png" ] && [ ! -e "$T/n.depth.png" ] &&
    cmp -s "$T/s.depth.png" "$T/a.depth.png"; then
    ok cli-aov-scene-default
else
    bad cli-aov-scene-default "render.aov: [\"depth\"] did not write s.depth.png alone, or none wrote one"
fi

# Bad values: a usage error (status 2) naming what is wrong; nothing written.
refused() {
    local name=$1 want=$2; shift 2
    "$R" "$S" "$@" >/dev/null 2>"$T/err"
    local rc=$?
    if [ $rc = 2 ] && grep -q -- "$want" "$T/err"; then ok "$name"; else bad "$name" "status $rc: $(cat "$T/err")"; fi
}
refused cli-aov-unknown "'zdepth' is no AOV" -o "$T/x.png" --aov zdepth
refused cli-aov-empty-name "empty name" -o "$T/x.png" --aov albedo,,depth
refused cli-aov-trailing-comma "empty name" -o "$T/x.png" --aov albedo,
refused cli-aov-no-value "takes a list of AOVs" -o "$T/x.png" --aov
refused cli-aov-stdout "standard output" -o - --aov depth
refused cli-alpha-exr "A channel" -o "$T/x.exr" --alpha
[ ! -e "$T/x.png" ] && [ ! -e "$T/x.exr" ] && ok cli-aov-refused-writes-nothing ||
    bad cli-aov-refused-writes-nothing "a refused command wrote a file"
python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); s["render"]["aov"]=["albedo", "Z"]; print(json.dumps(s))' "$S" >"$T/bad.json"
"$R" "$T/bad.json" -o "$T/x.png" 2>"$T/err"
rc=$?
[ $rc = 1 ] && grep -q '/render/aov/1: is no AOV' "$T/err" && ok cli-aov-bad-scene ||
    bad cli-aov-bad-scene "status $rc: $(cat "$T/err")"
