#!/usr/bin/env bash
# cli_frames.sh -- rayd-render on animated scenes: --frame, --frames A-B
# with an -o pattern, --video (read back with ffprobe: codec, frame count,
# size, rate), frame k the same bytes on any thread count, tiling or range,
# a video stopped by a signal leaving no part file, and the command line's
# mistakes (exit 2, one line naming them).
set -u
cd "$RAYD_ROOT"
R="$RAYD_BUILD/rayd-render"
CMP="$RAYD_BUILD/tests/tools/pngcmp"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
ok() { echo "PASS $1"; }
bad() { echo "FAIL $1: $2"; }
check() { local name=$1; shift; if "$@"; then ok "$name"; else bad "$name" "${WHY:-check failed}"; fi; }
run() { timeout 120 "$R" "$@"; }

cp "$RAYD_ROOT/tests/integration/lib/anim.json" "$T/anim.json" # frames 2-9, 48x32

# --frames A-B: one file a frame, named by the pattern; a line a frame and one for the range
if run "$T/anim.json" --frames 3-6 -o "$T/f-%03d.png" --threads 2 2>"$T/log"; then
    n=$(ls "$T"/f-*.png 2>/dev/null | wc -l)
    WHY="files: $(ls "$T" | tr '\n' ' ')"
    check frames_files [ "$n" = 4 -a -f "$T/f-003.png" -a -f "$T/f-006.png" ]
    WHY="stderr: $(tr '\n' '|' <"$T/log")"
    check frames_lines [ "$(grep -c '^frame [3-6]: .* \[[1-4]/4 frames' "$T/log")" = 4 -a \
                         "$(grep -c '^frames 3-6: 4 frames in ' "$T/log")" = 1 ]
else
    bad frames_files "exit $?: $(tr '\n' '|' <"$T/log")"
fi

# frame k alone equals frame k of the range, on any thread count, and any tiling
run "$T/anim.json" --frame 5 -o "$T/k1.png" --threads 1 -q 2>"$T/log"
run "$T/anim.json" --frame 5 -o "$T/k4.png" --threads 4 -q 2>>"$T/log"
WHY="$(tr '\n' '|' <"$T/log")"
check frame_alone_equals_range cmp -s "$T/k1.png" "$T/f-005.png"
check frame_threads_equal cmp -s "$T/k1.png" "$T/k4.png"
tiles_ok=1
for reg in 0,0,48,16 0,16,48,16 0,0,17,32 17,0,31,32; do
    run "$T/anim.json" --frame 5 --region "$reg" -o "$T/tile.png" --threads 3 -q 2>/dev/null || tiles_ok=0
    IFS=, read -r x y _ _ <<<"$reg"
    "$CMP" "$T/k1.png" "$T/tile.png" "$x" "$y" 2>/dev/null || tiles_ok=0
done
WHY="a tile of frame 5 differs from the frame's crop"
check frame_tiles_equal [ "$tiles_ok" = 1 ]
WHY="frames 3 and 6 are the same image: nothing moved"
check frames_differ bash -c '! cmp -s "$0" "$1"' "$T/f-003.png" "$T/f-006.png"
# the default is the first frame
run "$T/anim.json" -o "$T/first.png" -q 2>/dev/null
run "$T/anim.json" --frame 2 -o "$T/k2.png" -q 2>/dev/null
check default_first_frame cmp -s "$T/first.png" "$T/k2.png"

# mistakes: exit 2, one line naming them, nothing written
usage() { # NAME WANT ARGS...
    local name=$1 want=$2; shift 2
    run "$@" >/dev/null 2>"$T/err"
    local rc=$?
    WHY="exit $rc, stderr: $(tr '\n' '|' <"$T/err")"
    check "$name" bash -c '[ "$0" = 2 ] && grep -qF -- "$1" "$2"' "$rc" "$want" "$T/err"
}
usage frames_outside "rayd-render: error: $T/anim.json: /animation: frame 12 is outside the animation's frames 2-9" \
    "$T/anim.json" --frames 5-12 -o "$T/x%d.png"
usage frame_before_start "rayd-render: error: $T/anim.json: /animation: frame 1 is outside the animation's frames 2-9" \
    "$T/anim.json" --frame 1 -o "$T/x.png"
usage frames_need_pattern "a range of frames needs a file name with %d" "$T/anim.json" --frames 3-4 -o "$T/x.png"
usage frames_bad_pattern "a frame's file takes one %d (or %0Nd, N < 10) and no other % (%% for a %)" \
    "$T/anim.json" --frames 3-4 -o "$T/x-%s.png"
# %5d padded with spaces: "x-    3.png", names a shell splits (before, written as such)
usage frames_space_pattern "a frame's file takes one %d (or %0Nd, N < 10)" \
    "$T/anim.json" --frames 3-4 -o "$T/x-%5d.png"
usage frames_bad_pattern_00 "a frame's file takes one %d (or %0Nd, N < 10)" \
    "$T/anim.json" --frames 3-4 -o "$T/x-%00d.png"
usage frames_backwards "--frames takes A-B" "$T/anim.json" --frames 6-3 -o "$T/x%d.png"
usage frames_stdout "-o - cannot take a range of frames" "$T/anim.json" --frames 3-4 -o -
usage still_frame "rayd-render: error: frame 1: the scene has no /animation, so its one frame is 0" \
    scenes/paper.json --frame 1 -o "$T/x.png"
usage video_extension "--video writes H.264 in .mp4, .mov or .mkv" "$T/anim.json" --video "$T/v.avi"
WHY="$(ls "$T" | tr '\n' ' ')"
check mistakes_write_nothing bash -c '! ls "$0"/x* >/dev/null 2>&1' "$T"

# A frame past the first whose keyframed value fails (a smooth curve overshooting fov_x's
# 179 from frame 4 on): said before any frame renders.  Before, frames 0-3 were written.
cat >"$T/dip.json" <<'JSON'
{"animation": {"end": 20}, "render": {"width": 8, "height": 8},
 "camera": {"interpolation": "smooth", "keyframes": [{"frame": 0, "fov_x": 170},
            {"frame": 10, "fov_x": 179}, {"frame": 20, "fov_x": 20}]},
 "objects": [{"type": "sphere"}]}
JSON
run "$T/dip.json" --frames 0-20 -o "$T/dip-%d.png" -q 2>"$T/err"
rc=$?
WHY="exit $rc, stderr: $(tr '\n' '|' <"$T/err"), $(ls "$T" | grep -c dip-) frames written"
check later_frame_fails_before_any bash -c '[ "$0" = 1 ] &&
    grep -q "/camera/keyframes: at frame 4, fov_x: must be <= 179" "$1" && ! ls "$2"/dip-* >/dev/null 2>&1' \
    "$rc" "$T/err" "$T"
run "$T/dip.json" --frames 0-3 -o "$T/nodir/dip-%d.png" -q 2>"$T/err"
rc=$?
WHY="exit $rc, stderr: $(tr '\n' '|' <"$T/err")"
check frames_folder_missing_said_first bash -c '[ "$0" = 1 ] &&
    grep -q "cannot write .*nodir/dip-0.png: No such file" "$1" && ! grep -q "^frame 0" "$1"' \
    "$rc" "$T/err"
run "$T/dip.json" --frames 12-20 -o "$T/dip-%d.png" -q 2>"$T/err"
WHY="exit $?, stderr: $(tr '\n' '|' <"$T/err")"
check frames_after_dip_render bash -c '[ -s "$0"/dip-12.png ] && [ -s "$0"/dip-20.png ]' "$T"

# --video: every frame of the scene by default, H.264 in MP4, the scene's rate and size
probe() { ffprobe -v error -select_streams v:0 -count_frames \
    -show_entries stream=codec_name,width,height,r_frame_rate,nb_read_frames -of default=nw=1 "$1"; }
if ! command -v ffprobe >/dev/null; then
    bad video "no ffprobe (make deps installs ffmpeg)"
else
    if run "$T/anim.json" --video "$T/all.mp4" -q 2>"$T/log"; then
        probe "$T/all.mp4" >"$T/p" 2>&1
        WHY="ffprobe: $(tr '\n' ' ' <"$T/p")"
        check video_all_frames grep -qx 'nb_read_frames=8' "$T/p"
        check video_h264 grep -qx 'codec_name=h264' "$T/p"
        check video_size bash -c 'grep -qx width=48 "$0" && grep -qx height=32 "$0"' "$T/p"
        check video_rate grep -qx 'r_frame_rate=12/1' "$T/p"
        fmt=$(ffprobe -v error -show_entries format=format_name -of default=nw=1:nk=1 "$T/all.mp4")
        WHY="format $fmt"
        check video_mp4 bash -c '[[ "$0" == *mp4* ]]' "$fmt"
    else
        bad video_all_frames "exit $?: $(tr '\n' '|' <"$T/log")"
    fi
    # a range with its frames written too: the files are the plain frames' bytes
    if run "$T/anim.json" --frames 4-6 --video "$T/part.mp4" -o "$T/v-%d.png" --region 2,2,40,26 \
        -q 2>"$T/log"; then
        probe "$T/part.mp4" >"$T/p" 2>&1
        WHY="ffprobe: $(tr '\n' ' ' <"$T/p")"
        check video_range_frames bash -c 'grep -qx nb_read_frames=3 "$0" && grep -qx width=40 "$0" && grep -qx height=26 "$0"' "$T/p"
        run "$T/anim.json" --frame 5 --region 2,2,40,26 -o "$T/r5.png" -q 2>/dev/null
        WHY="v-5.png differs from --frame 5's"
        check video_frame_files cmp -s "$T/v-5.png" "$T/r5.png"
    else
        bad video_range_frames "exit $?: $(tr '\n' '|' <"$T/log")"
    fi
    # a run that fails part way leaves the video there was, and no part of its own: ffmpeg
    # writes FILE.PID.part.mp4, renamed over FILE once whole.  Before, the video was
    # replaced by the frames made until the failure (here frame 9's file, a folder).
    cp "$T/part.mp4" "$T/keep.mp4"
    mkdir -p "$T/vd-9.png"
    run "$T/anim.json" --frames 2-9 --video "$T/keep.mp4" -o "$T/vd-%d.png" -q 2>"$T/err"
    rc=$?
    WHY="exit $rc: $(tr '\n' '|' <"$T/err"); $(ls "$T" | grep keep)"
    check video_failed_run_keeps_old bash -c '[ "$0" = 1 ] && cmp -s "$1/part.mp4" "$1/keep.mp4" &&
        ! ls "$1"/keep.mp4.*part* >/dev/null 2>&1 && [ -s "$1/vd-2.png" ]' "$rc" "$T"
    run "$T/anim.json" --frames 2-4 --video "$T/keep.mp4" -q 2>"$T/err"
    WHY="exit $?: $(tr '\n' '|' <"$T/err")"
    check video_replaced_when_whole bash -c '! cmp -s "$0/part.mp4" "$0/keep.mp4" &&
        ! ls "$0"/keep.mp4.*part* >/dev/null 2>&1' "$T"
    # the part file is made new: a link planted at its name (in a shared folder, the PID
    # guessed) is passed over, and the file it points to is not written through it
    echo untouched >"$T/victim"
    (cd "$T" && bash -c 'ln -s victim planted.mp4.$$.part.mp4; exec "$0" "$1" --frames 2-3 --video planted.mp4 -q' \
        "$R" "$T/anim.json" 2>"$T/err")
    WHY="exit $?: $(tr '\n' '|' <"$T/err"); victim: $(head -c 40 "$T/victim" | tr -d '\0')"
    check video_part_not_through_link bash -c '[ "$(cat "$0/victim")" = untouched ] && [ -s "$0/planted.mp4" ] &&
        [ ! -L "$0/planted.mp4" ]' "$T"
    # SIGTERM (a service manager, timeout(1)) or SIGHUP in the middle of a video: ffmpeg is
    # killed and waited for, the part file removed, and the exit status the signal's.  Before,
    # only a run that failed removed it: one stopped so left FILE.PID.part.mp4 behind.
    python3 - "$T/anim.json" "$T/long.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["animation"]["end"] = 2000  # frames for minutes: the run is stopped long before
s["render"].update(width=128, height=96, samples=64)
json.dump(s, open(sys.argv[2], "w"))
PY
    for sig in TERM HUP; do
        mkdir "$T/sig-$sig"
        "$R" "$T/long.json" --video "$T/sig-$sig/v.mp4" --threads 1 2>"$T/sig-$sig.err" &
        pid=$!
        for _ in $(seq 1200); do grep -q '^frame 2: ' "$T/sig-$sig.err" && break; sleep 0.1; done
        ffpid=$(tr -d ' ' <"/proc/$pid/task/$pid/children" 2>/dev/null) # its one child
        before=$(ls "$T/sig-$sig")
        kill "-$sig" "$pid"
        wait "$pid" 2>/dev/null # the shell's "Hangup" is no failure
        rc=$?
        WHY="exit $rc, ffmpeg $ffpid, before: $before, after: $(ls "$T/sig-$sig"); $(tail -2 "$T/sig-$sig.err" | tr '\n' '|')"
        check "video_sig${sig}_removes_part" bash -c '[ "$0" = $((128 + $(kill -l "$1"))) ] &&
            [[ "$2" == v.mp4.*.part.mp4 ]] && [ -z "$(ls "$3")" ] && [ -n "$4" ] && [ ! -e "/proc/$4" ]' \
            "$rc" "$sig" "$before" "$T/sig-$sig" "$ffpid"
    done
    # no ffmpeg on the PATH: exit 1, said
    PATH=/nonexistent "$R" "$T/anim.json" --video "$T/none.mp4" -q 2>"$T/err"
    rc=$?
    WHY="exit $rc: $(tr '\n' '|' <"$T/err")"
    check video_without_ffmpeg bash -c '[ "$0" = 1 ] && grep -q "needs the ffmpeg program" "$1"' "$rc" "$T/err"
fi
exit 0
