#!/usr/bin/env bash
# thumbnails.sh -- rayd-client thumbnails: a folder of models others made
# (Debian's assimp-testmodels: PLY files and .glb files), plus one broken
# file, rendered over one rayd.  Each good model gives OUTDIR/NAME.png of
# the asked size, showing the model (pixels unlike the plain studio
# background at the corner); the broken one gives an error line naming it
# and the exit status is 1 while the others are still written.
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
"$CLIENT" thumbnails "$T/models" -o "$T/top" --size 32 --view top -s "$URL" 2>"$T/top.err"
rc=$?
size=$( [ -f "$T/top/cube.png" ] && png_size "$T/top/cube.png")
check thumbnails_all_good_exit_0 "exit $rc, cube.png $size: $(cat "$T/top.err")" \
    bash -c "[ $rc = 0 ] && [ '$size' = 32x32 ] && [ -f '$T/top/BoxTextured.png' ]"
"$CLIENT" thumbnails "$T/models" --view back -s "$URL" 2>"$T/bad.err"
rc=$?
check thumbnails_bad_view_usage "exit $rc: $(cat "$T/bad.err")" \
    bash -c "[ $rc = 2 ] && grep -q -- '--view needs' '$T/bad.err'"
stop_rayd
exit $((NFAIL > 0))
