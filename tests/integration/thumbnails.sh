#!/usr/bin/env bash
# thumbnails.sh -- rayd-client thumbnails: a folder of models others made
# (Debian's assimp-testmodels: PLY files and .glb files), plus one broken
# file, rendered over one rayd.  Each good model gives OUTDIR/NAME.png of
# the asked size, showing the model (pixels unlike the plain studio
# background at the corner); the broken one gives an error line naming it
# and the exit status is 1 while the others are still written.  Then
# --turntable: N distinct frames, frame 0 the plain thumbnail, frame 1 of 4
# from the front the side view; bad counts are usage errors.
source "$(dirname "$0")/lib/common.sh"
CLIENT=$RAYD_BUILD/rayd-client
FRAME="$RAYD_ROOT/tests/integration/lib/gltf_frame.py"
A=/usr/share/assimp/models
if [ ! -d "$A/PLY" ] || [ ! -d "$A/glTF2" ]; then
    fail assimp_testmodels "missing $A (make test-deps installs assimp-testmodels)"
    exit 1
fi
mkdir -p "$T/models"
cp "$A/PLY/cube.ply" "$A/PLY/Wuson.ply" "$T/models/"
cp "$A/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb" "$T/models/"
cp "$A/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb" "$T/models/"
printf 'ply\nformat ascii 1.0\nelement vertex 3\nend_header\n0 0\n' >"$T/models/broken.ply"
echo "not a model" >"$T/models/notes.txt"

start_rayd --threads 2
"$CLIENT" thumbnails "$T/models" -o "$T/out" --size 48 -s "$URL" 2>"$T/client.err"
rc=$?
check thumbnails_exit_1_with_a_broken_model "exit $rc: $(head -c 600 "$T/client.err")" [ "$rc" = 1 ]
for name in cube Wuson BoxTextured 2CylinderEngine; do
    png="$T/out/$name.png"
    if ! [ -f "$png" ] || ! is_png "$png"; then
        fail "thumbnail_$name" "no PNG written: $(cat "$T/client.err")"
        continue
    fi
    size=$(png_size "$png")
    lit=$(python3 "$FRAME" lit "$png")
    model=$(python3 "$FRAME" unlike_corner "$png")
    check "thumbnail_$name" "$size, $lit lit pixels, $model unlike the corner" \
        bash -c "[ $size = 48x48 ] && [ $lit -gt 0 ] && [ $model -gt 48 ]"
    check "thumbnail_line_$name" "no line for it: $(cat "$T/client.err")" \
        grep -q "^rayd-client: thumbnail .*/$name\.[a-z]* -> .*/$name\.png$" "$T/client.err"
done
check thumbnail_broken_reported "$(cat "$T/client.err")" \
    grep -q "^rayd-client: error: .*/broken\.ply: .*/objects/0/source" "$T/client.err"
check thumbnail_broken_not_written "broken.png exists" [ ! -e "$T/out/broken.png" ]
check thumbnail_other_files_skipped "notes.png exists" [ ! -e "$T/out/notes.png" ]
nlines=$(wc -l <"$T/client.err")
check thumbnails_one_line_a_model "$nlines lines: $(cat "$T/client.err")" [ "$nlines" = 5 ]

# a view and no failures: exit 0
rm "$T/models/broken.ply" "$T/models/Wuson.ply" "$T/models/2CylinderEngine.glb"
"$CLIENT" thumbnails "$T/models/" -o "$T/top/" --size 32 --view top -s "$URL" 2>"$T/top.err"
rc=$?
size=$( [ -f "$T/top/cube.png" ] && png_size "$T/top/cube.png")
check thumbnails_all_good_exit_0 "exit $rc, cube.png $size: $(cat "$T/top.err")" \
    bash -c "[ $rc = 0 ] && [ '$size' = 32x32 ] && [ -f '$T/top/BoxTextured.png' ]"
# the folders were typed with a trailing slash: the names printed have no "//"
check thumbnails_no_double_slash "$(cat "$T/top.err")" \
    bash -c "grep -q 'models/cube' '$T/top.err' && ! grep -q '//' '$T/top.err'"
"$CLIENT" thumbnails "$T/models" --view back -s "$URL" 2>"$T/bad.err"
rc=$?
check thumbnails_bad_view_usage "exit $rc: $(cat "$T/bad.err")" \
    bash -c "[ $rc = 2 ] && grep -q -- '--view needs' '$T/bad.err'"

# --turntable N: N frames a model at azimuths the view's + 360 k / N.  From
# the front (azimuth 0, elevation 0), frame 1 of 4 is azimuth 90: the side
# view, byte for byte; frame 0 is always the plain thumbnail.
mkdir -p "$T/turn"
cp "$A/PLY/Wuson.ply" "$T/turn/"
tt() { # tt OUTDIR ARGS...: thumbnails of $T/turn at 32 pixels; sets rc
    local out=$1; shift
    "$CLIENT" thumbnails "$T/turn" -o "$T/$out" --size 32 -s "$URL" "$@" 2>"$T/$out.err"
    rc=$?
}
tt front --view front
tt side --view side
tt tq
tt turn4 --view front --turntable 4
check turntable_exit_0 "exit $rc: $(cat "$T/turn4.err")" [ "$rc" = 0 ]
files=$(cd "$T/turn4" 2>/dev/null && ls | tr '\n' ' ')
check turntable_writes_n_files "$files" [ "$files" = "Wuson-000.png Wuson-001.png Wuson-002.png Wuson-003.png " ]
check turntable_frames_distinct "$(md5sum "$T"/turn4/*.png 2>&1)" [ "$(md5sum "$T"/turn4/Wuson-*.png | cut -d' ' -f1 | sort -u | wc -l)" = 4 ]
check turntable_frame_0_is_the_view "differs from the front thumbnail" \
    cmp -s "$T/turn4/Wuson-000.png" "$T/front/Wuson.png"
check turntable_azimuth_90_is_side "differs from the side thumbnail" \
    cmp -s "$T/turn4/Wuson-001.png" "$T/side/Wuson.png"
nlines=$(wc -l <"$T/turn4.err")
check turntable_one_line_a_frame "$(cat "$T/turn4.err")" [ "$nlines" = 4 ]
tt turn3 --turntable 3
check turntable_three_quarter_frame_0 "exit $rc: $(cat "$T/turn3.err")" \
    bash -c "[ $rc = 0 ] && cmp -s '$T/turn3/Wuson-000.png' '$T/tq/Wuson.png' &&
        [ -f '$T/turn3/Wuson-002.png' ] && [ ! -e '$T/turn3/Wuson-003.png' ]"
for bad in 0 361 2.5 x -1 ''; do
    tt "bad$bad" --turntable "$bad"
    check "turntable_refuses_'$bad'" "exit $rc: $(cat "$T/bad$bad.err")" \
        bash -c "[ $rc = 2 ] && grep -q -- '^rayd-client: error: --turntable needs' '$T/bad$bad.err' &&
            [ ! -e '$T/bad$bad' ]"
done

# Two models whose names differ only in the extension would write the same
# PNGs.  The clash is found before rendering: the later in name order
# (cube.ply after cube.glb, the textured box under another name) is skipped
# in one error line naming both and the PNG, the first one's PNG is kept
# (the box's thumbnail from above, byte for byte), a model of another name
# still gets its NAME.png, and the run exits 1.  The same for a turntable.
mkdir -p "$T/clash"
cp "$A/PLY/cube.ply" "$T/clash/cube.ply"
cp "$A/PLY/cube.ply" "$T/clash/alone.ply"
cp "$A/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb" "$T/clash/cube.glb"
# clash OUT ARGS...: thumbnails of $T/clash at 48 pixels into $T/OUT; sets
# rc and files (the PNGs written)
clash() {
    local out=$1; shift
    "$CLIENT" thumbnails "$T/clash" -o "$T/$out" --size 48 -s "$URL" "$@" 2>"$T/$out.err"
    rc=$?
    files=$(cd "$T/$out" 2>/dev/null && ls | tr '\n' ' ')
}
said="rayd-client: error: $T/clash/cube.ply: skipped: $T/clash/cube.glb, of the same name but for the extension, writes"
clash clash1
check thumbnails_same_name_exit_1 "exit $rc: $(cat "$T/clash1.err")" [ "$rc" = 1 ]
check thumbnails_same_name_said "$(cat "$T/clash1.err")" \
    grep -qxF "$said $T/clash1/cube.png" "$T/clash1.err"
check thumbnails_same_name_first_kept "files $files; $(cat "$T/clash1.err")" bash -c \
    "[ '$files' = 'alone.png cube.png ' ] && cmp -s '$T/clash1/cube.png' '$T/out/BoxTextured.png' &&
        cmp -s '$T/clash1/alone.png' '$T/out/cube.png'"
nlines=$(wc -l <"$T/clash1.err")
check thumbnails_same_name_one_line_a_model "$(cat "$T/clash1.err")" [ "$nlines" = 3 ]
clash clash3 --turntable 3
check turntable_same_name_said "exit $rc: $(cat "$T/clash3.err")" bash -c \
    '[ "$1" = 1 ] && grep -qxF "$2" "$3"' _ "$rc" \
    "$said $T/clash3/cube-000.png ... cube-002.png" "$T/clash3.err"
check turntable_same_name_first_kept "files $files" bash -c \
    "[ '$files' = 'alone-000.png alone-001.png alone-002.png cube-000.png cube-001.png cube-002.png ' ] &&
        cmp -s '$T/clash3/cube-000.png' '$T/out/BoxTextured.png'"
stop_rayd

# One failure, one error line: a server whose --max-work refuses the
# thumbnail's scene; the line names the model and gives the server's error.
start_rayd --threads 1 --max-work 1000
"$CLIENT" thumbnails "$T/turn" -o "$T/refused" --size 32 -s "$URL" 2>"$T/refused.err"
rc=$?
check thumbnails_refused_one_line "exit $rc: $(cat "$T/refused.err")" bash -c \
    "[ $rc = 1 ] && [ \$(wc -l <'$T/refused.err') = 1 ] && [ ! -e '$T/refused/Wuson.png' ] &&
        grep -q '^rayd-client: error: $T/turn/Wuson.ply: $URL refused the scene: HTTP 413 over_budget' '$T/refused.err'"
stop_rayd
exit $((NFAIL > 0))
