#!/usr/bin/env bash
# programs_output.sh -- rayd-render and rayd-client write -o whole or not at all.
#
# Both write a new temporary file in the output's folder, fsync it and
# rename it over the output (programs/common/output.c).  A write that fails
# must leave an existing output byte for byte as it was, or no output at
# all, and no temporary file; a run killed in the middle of its write must
# leave the old output whole.  The file size limit (ulimit -f 4: 4 KiB, the
# images here are larger) stands in for both, deterministically: with
# SIGXFSZ ignored, the write past the limit fails with EFBIG, as on a full
# disk; with SIGXFSZ left alone, the kernel kills the program at that write.
# A replaced file keeps its permission bits, a symbolic link stays a link
# (to the new image), and a FIFO is written in place, not replaced.  When
# every temporary name is taken the run fails and removes none of them.
source "$(dirname "$0")/lib/common.sh"

CLIENT=$RAYD_BUILD/rayd-client
[ -x "$CLIENT" ] || { echo "FAIL setup: $CLIENT missing"; exit 1; }

scene "$T/s.json" 128 96 1 spheres # its PNG is ~15 KB, its EXR ~120 KB
head -c 65536 /dev/urandom >"$T/old"

# limited KIND CMD...: CMD with a 4 KiB file size limit, stdout and stderr
# in $T/out and $T/err; KIND "full" ignores SIGXFSZ (writes fail: EFBIG),
# "killed" lets it kill CMD in the middle of its write.  Sets RC.
limited() {
    local kind=$1
    shift
    ( # no exec: this shell, not the script's, says "File size limit exceeded"
        ulimit -c 0 -f 4
        [ "$kind" = full ] && trap '' XFSZ
        timeout 120 "$@"
        exit $?
    ) >"$T/out" 2>"$T/err"
    RC=$?
}
# no_part DIR NAME: no temporary file of output NAME is left in DIR
no_part() { [ -z "$(find "$1" -maxdepth 1 -name "$2*.part")" ]; }
# old_at FILE: FILE is the old bytes, untouched
old_at() { cmp -s "$T/old" "$1"; }
says() { tr '\n' '|' <"$T/err" | head -c 300; }

# failed_write NAME PROG OUT CMD...: CMD (writing OUT, PROG's) with writes
# failing: exit 1, the error names OUT, OUT is the old file (NAME_old_kept)
# or none (NAME_none), no temporary file either way.
failed_write() {
    local name=$1 prog=$2 out=$3
    shift 3
    cp "$T/old" "$out"
    limited full "$@"
    check "${name}_old_kept" "exit $RC, $(says), $(ls -l "$(dirname "$out")" | tr '\n' '|')" \
        bash -c "[ $RC = 1 ] && cmp -s '$T/old' '$out' && grep -q '^$prog: error: cannot write $out: File too large' '$T/err'"
    check "${name}_old_kept_no_part" "$(ls "$(dirname "$out")" | tr '\n' ' ')" \
        no_part "$(dirname "$out")" "$(basename "$out")"
    rm -f "$out"
    limited full "$@"
    check "${name}_none" "exit $RC, $(says), $(ls -l "$(dirname "$out")" | tr '\n' '|')" \
        bash -c "[ $RC = 1 ] && [ ! -e '$out' ]"
    check "${name}_none_no_part" "$(ls "$(dirname "$out")" | tr '\n' ' ')" \
        no_part "$(dirname "$out")" "$(basename "$out")"
}

# killed_write NAME OUT CMD...: CMD killed by SIGXFSZ in its write of OUT:
# the old OUT whole (a temporary file may be left: a killed run cannot
# clean up, but it is never OUT).
killed_write() {
    local name=$1 out=$2
    shift 2
    cp "$T/old" "$out"
    limited killed "$@"
    check "${name}_killed_old_kept" "exit $RC, $(says), $(ls -l "$(dirname "$out")" | tr '\n' '|')" \
        bash -c "[ $RC -gt 128 ] && cmp -s '$T/old' '$out'"
    rm -f "$out" "$out".*part
}

# replaced NAME OUT CMD...: CMD writing over an existing OUT of mode
# 640 through a symbolic link: the link stays, its target is the new PNG
# with mode 640; then a FIFO as OUT is written in place.
replaced() {
    local name=$1 out=$2 d
    shift 2
    d=$(dirname "$out")
    cp "$T/old" "$d/target.png"
    chmod 640 "$d/target.png"
    ln -sf target.png "$out"
    timeout 120 "$@" >"$T/out" 2>"$T/err"
    RC=$?
    check "${name}_replaced" "exit $RC, $(says)" bash -c "[ $RC = 0 ] && [ -L '$out' ]"
    check "${name}_replaced_through_link" "$(ls -l "$d" | tr '\n' '|')" \
        bash -c "head -c 8 '$d/target.png' | od -An -tx1 | tr -d ' \n' | grep -qx 89504e470d0a1a0a && [ \"\$(stat -c %a '$d/target.png')\" = 640 ]"
    check "${name}_replaced_no_part" "$(ls "$d" | tr '\n' ' ')" no_part "$d" target.png
    rm -f "$out" "$d/target.png"
    mkfifo "$out"
    cat "$out" >"$T/fifo.got" &
    local cat_pid=$!
    PIDS+=("$cat_pid")
    timeout 120 "$@" >"$T/out" 2>"$T/err"
    RC=$?
    # a program that replaced the FIFO left the reader without a writer
    wait_until 30 bash -c "! kill -0 $cat_pid 2>/dev/null"
    kill "$cat_pid" 2>/dev/null
    wait "$cat_pid" 2>/dev/null
    check "${name}_fifo_in_place" "exit $RC, $(says)" \
        bash -c "[ $RC = 0 ] && [ -p '$out' ] && head -c 8 '$T/fifo.got' | od -An -tx1 | tr -d ' \n' | grep -qx 89504e470d0a1a0a"
    rm -f "$out"
}

# --- rayd-render: the streamed PNG, and the EXR written in one piece --------
mkdir -p "$T/r"
failed_write render_png rayd-render "$T/r/out.png" "$RENDER" "$T/s.json" -o "$T/r/out.png" -q
failed_write render_exr rayd-render "$T/r/out.exr" "$RENDER" "$T/s.json" -o "$T/r/out.exr" -q
killed_write render_png "$T/r/out.png" "$RENDER" "$T/s.json" -o "$T/r/out.png" -q
replaced render "$T/r/link.png" "$RENDER" "$T/s.json" -o "$T/r/link.png" -q

# --- every temporary name taken: refused, and none of them removed -----------
# The shell that execs rayd-render has its PID, so OUT.PID.part and OUT.PID-1..99.part
# (the hundred names output_part tries) are made first, as another run's files.  The
# run fails with EEXIST and the hundred stay; before, the last name tried was removed.
mkdir -p "$T/taken"
bash -c 'for i in "" $(seq -f -%g 1 99); do echo other >"$1/out.png.$$$i.part"; done
    exec "$0" "$2" -o "$1/out.png" -q' "$RENDER" "$T/taken" "$T/s.json" >"$T/out" 2>"$T/err"
RC=$?
check render_part_names_taken "exit $RC, $(says), $(ls "$T/taken" | grep -c 'part$') of 100 left" \
    bash -c "[ $RC = 1 ] && grep -q '^rayd-render: error: cannot write $T/taken/out.png: File exists' '$T/err' &&
        [ \"\$(grep -lx other '$T/taken'/out.png.*.part | wc -l)\" = 100 ] && [ ! -e '$T/taken/out.png' ]"

# SIGTERM (a service manager, timeout(1)) while the file is written: the part file goes too, and
# the exit status is the signal's.  Before, it was left: out.exr.PID.part beside no out.exr.  The
# write of a 4096x4096 EXR (29 MB) takes about 0.1 s; the signal is sent when the part file is
# seen, the run tried again (up to 5 times) if it ended before it was.
cat >"$T/big.json" <<'JSON'
{"render": {"width": 4096, "height": 4096}, "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
 "lights": [{"type": "point", "position": [3, 3, 5]}], "objects": [{"type": "sphere", "radius": 1.5}]}
JSON
mkdir -p "$T/sig"
python3 - "$T/sig" "$RENDER" "$T/big.json" >"$T/sig.out" <<'PY'
import os, subprocess, sys, time
d, render, scene = sys.argv[1:4]
for attempt in range(5):
    p = subprocess.Popen([render, scene, "-o", os.path.join(d, "out.exr"), "-q"])
    seen = []
    while p.poll() is None and not seen:
        seen = [f for f in os.listdir(d) if f.endswith(".part")]
        time.sleep(0.002)
    if seen:
        p.terminate()
        p.wait()
        left = sorted(os.listdir(d))
        if p.returncode == -15 or any(f.endswith(".part") for f in left):
            print("caught", p.returncode, " ".join(left) or "-")
            break
    p.wait()  # it renamed the file into place before the signal came: again
    for f in os.listdir(d):
        os.unlink(os.path.join(d, f))
else:
    print("never caught")
PY
check render_sigterm_removes_part "$(cat "$T/sig.out")" grep -qx 'caught -15 -' "$T/sig.out"

# --- rayd-client: render (tiles) and job -------------------------------------
start_rayd --threads 2
mkdir -p "$T/c"
failed_write client_render rayd-client "$T/c/out.png" \
    "$CLIENT" render "$T/s.json" -o "$T/c/out.png" --server "$URL" -q
failed_write client_job rayd-client "$T/c/job.png" \
    "$CLIENT" job "$T/s.json" -o "$T/c/job.png" --server "$URL" -q
killed_write client_render "$T/c/out.png" "$CLIENT" render "$T/s.json" -o "$T/c/out.png" \
    --server "$URL" -q
replaced client "$T/c/link.png" "$CLIENT" render "$T/s.json" -o "$T/c/link.png" --server "$URL" -q
stop_rayd
exit 0
