#!/usr/bin/env bash
# OpenEXR environment maps as artists' tools write them: every compression
# OpenEXR 3.1 has (DWAA and DWAB, Blender's and Nuke's default, through
# core/codec/exr_imf.cc), scanlines and tiles.  Each file is made by
# OpenEXR's own C++ library (tests/tools/exrtool.cc) from one float ramp
# and rendered with rayd-render, looking straight at the map.  The lossless
# ones (and PXR24, lossless on halves) must give the very bytes of the
# uncompressed file's render; the lossy ones (B44, B44A, DWAA, DWAB) the
# same image within 2% per value, read back from the EXR output.  A deep
# file, a truncated DWA file and a DWA file with a scrambled middle are
# refused with a message naming the file and what is wrong, never a crash.
set -u
cd "$RAYD_ROOT"
R="$RAYD_BUILD/rayd-render"
X="$RAYD_BUILD/tests/tools/exrtool"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
ok() { echo "PASS $1"; }
bad() { echo "FAIL $1: $2"; }

# scene MAP: the camera looks into the environment, nothing else there.
scene() {
    printf '{"camera": {"position": [0, 0, 0], "look_at": [0, 0, -1], "fov_x": 120},
  "render": {"width": 48, "height": 24, "environment": {"file": "%s"}}, "objects": []}\n' "$1"
}

"$X" ramp "$T/ramp.exr" && "$X" rewrite "$T/ramp.exr" "$T/none.exr" none ||
    { bad exrtool "cannot make the maps"; exit 0; }
scene none.exr >"$T/none.json"
(cd "$T" && "$R" none.json -o ref.png 2>err && "$R" none.json -o ref.exr 2>>err) ||
    { bad reference "$(cat "$T/err")"; exit 0; }

render() { # NAME COMPRESSION [tiled]: renders NAME.exr, made so
    "$X" rewrite "$T/ramp.exr" "$T/$1.exr" "$2" ${3:-} || return 1
    scene "$1.exr" >"$T/$1.json"
    (cd "$T" && "$R" "$1.json" -o "$1.png" 2>"$1.err" && "$R" "$1.json" -o "$1.out.exr" 2>>"$1.err")
}

for c in rle zips zip piz pxr24; do
    for form in "" tiled; do
        name=$c${form:+_$form}
        if ! render "$name" "$c" $form; then
            bad "map_$name" "$(cat "$T/$name.err" 2>/dev/null)"
        elif cmp -s "$T/ref.png" "$T/$name.png"; then
            ok "map_$name"
        else
            bad "map_$name" "the render differs from the uncompressed map's"
        fi
    done
done
render none_tiled none tiled && cmp -s "$T/ref.png" "$T/none_tiled.png" && ok map_none_tiled ||
    bad map_none_tiled "$(cat "$T/none_tiled.err" 2>/dev/null) differs or failed"

for c in b44 b44a dwaa dwab; do
    for form in "" tiled; do
        name=$c${form:+_$form}
        if ! render "$name" "$c" $form; then
            bad "map_$name" "$(cat "$T/$name.err" 2>/dev/null)"
        elif out=$("$X" diff "$T/ref.exr" "$T/$name.out.exr" 0.02); then
            ok "map_$name ($out)"
        else
            bad "map_$name" "$out"
        fi
    done
done

# refused() NAME FILE WHAT: rayd-render fails on the map, naming it and WHAT.
refused() {
    scene "$2" >"$T/$1.json"
    if (cd "$T" && "$R" "$1.json" -o "$1.png" 2>"$1.err"); then
        bad "$1" "rendered"
    elif grep -q '/render/environment/file' "$T/$1.err" && grep -qi "$3" "$T/$1.err" &&
        ! grep -qi 'sanitizer\|terminate' "$T/$1.err"; then
        ok "$1"
    else
        bad "$1" "$(head -c 300 "$T/$1.err")"
    fi
}
"$X" deep "$T/deep.exr" && refused deep_refused deep.exr "deep OpenEXR"
size=$(stat -c %s "$T/dwaa.exr")
head -c $((size * 2 / 3)) "$T/dwaa.exr" >"$T/cut.exr"
refused dwa_truncated cut.exr "OpenEXR"
python3 - "$T/dwaa.exr" "$T/scrambled.exr" <<'PY'
import sys
b = bytearray(open(sys.argv[1], 'rb').read())
for i in range(len(b) // 2, len(b) - 16):
    b[i] = (b[i] * 167 + 13) & 255
open(sys.argv[2], 'wb').write(bytes(b))
PY
# a scrambled chunk either decodes to some values or is refused; never a crash
scene scrambled.exr >"$T/scrambled.json"
(cd "$T" && "$R" scrambled.json -o scrambled.png 2>scrambled.err); rc=$?
if [ $rc -le 1 ] && ! grep -qi 'sanitizer\|terminate\|runtime error' "$T/scrambled.err"; then
    ok "dwa_scrambled (exit $rc)"
else
    bad dwa_scrambled "exit $rc: $(head -c 300 "$T/scrambled.err")"
fi
