#!/usr/bin/env bash
# cli_bad_scenes.sh -- rayd-render against the bad-scene corpus, and the
# command line's own errors.
#
#   RAYD_BUILD=$PWD/build RAYD_ROOT=$PWD bash tests/integration/cli_bad_scenes.sh
#   (or: bash tests/run.sh build, which sets both)
#
# For every line of tests/bad/scenes.tsv ("file<TAB>status<TAB>stderr line
# [<TAB>bug]") it runs `rayd-render tests/bad/scenes/FILE -o TMP.png` and
# checks the exit status, that the expected line is one whole line of stderr
# (with the scene's file named after "rayd-render: error: ", as rayd-render
# names it: "rayd-render: error: tests/bad/scenes/FILE: ...") and that no
# PNG was written.  Lines marked `bug` run too: they describe what
# the loader should do and fail until it does.  On `bug` lines only, `*` in the
# expected line matches any text (the rest is literal).
#
# Then: the stock scenes in scenes/ load and render (exit 0; a centred crop
# of at most 64 x 64, so that a path-traced scene stays quick), a scene on stdin ("-") gives the same bytes as the file, --region
# mistakes exit 2 (a usage error) with a clear message, and a missing scene
# file exits 1.  A bad scene exits 1 (docs: the exit status of the tools).
#
# One line per case: "PASS name" or "FAIL name: why".  Every run has a time
# limit, so a hang is a FAIL, not a stuck suite.
set -u
RAYD_ROOT=${RAYD_ROOT:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}
RAYD_BUILD=${RAYD_BUILD:-$RAYD_ROOT/build}
cd "$RAYD_ROOT" || exit 1
R="$RAYD_BUILD/rayd-render"
TSV=tests/bad/scenes.tsv
DIR=tests/bad/scenes
LIMIT=${RAYD_BAD_TIMEOUT:-30} # seconds per run
T=$(mktemp -d "${TMPDIR:-/tmp}/rayd-bad.XXXXXX")
trap 'rm -rf "$T"' EXIT

if [ ! -x "$R" ]; then
    echo "FAIL bad-scene-setup: $R is missing (make build/rayd-render)"
    exit 1
fi

# One line, at most 300 bytes, printable: for FAIL messages.
oneline() { tr '\n\t' '||' <"$1" | tr -c '[:print:]' '?' | head -c 300; }

# glob_of TEXT: TEXT as a bash pattern in which only '*' is special.
glob_of() {
    local s=$1 out='' c i
    for ((i = 0; i < ${#s}; i++)); do
        c=${s:i:1}
        case $c in
        '*') out+='*' ;;
        \\ | '?' | '[' | ']' | '(' | ')' | '|' | '!' | '+' | '@') out+="\\$c" ;;
        *) out+=$c ;;
        esac
    done
    printf '%s' "$out"
}

# has_line FILE EXPECTED IS_GLOB: a whole line of FILE equals EXPECTED.
has_line() {
    local file=$1 want=$2 glob=$3 line pat
    if [ "$glob" = 0 ]; then
        grep -qxF -- "$want" "$file"
        return
    fi
    pat=$(glob_of "$want")
    while IFS= read -r line || [ -n "$line" ]; do
        # shellcheck disable=SC2053
        [[ $line == $pat ]] && return 0
    done <"$file"
    return 1
}

# ---- the corpus ---------------------------------------------------------------
n=0
while IFS=$'\t' read -r file want_rc want_line mark || [ -n "$file" ]; do
    [ -z "$file" ] && continue
    case $file in '#'*) continue ;; esac
    n=$((n + 1))
    name="bad-scene $file"
    [ "${mark:-}" = bug ] && glob=1 || glob=0
    want_line="rayd-render: error: $DIR/$file: ${want_line#rayd-render: error: }"
    if [ ! -f "$DIR/$file" ]; then
        echo "FAIL $name: $DIR/$file does not exist"
        continue
    fi
    out="$T/out.png"
    rm -f "$out"
    timeout -k 5 "$LIMIT" "$R" "$DIR/$file" -o "$out" >"$T/stdout" 2>"$T/stderr"
    rc=$?
    why=
    if [ $rc -eq 124 ] || [ $rc -eq 137 ]; then
        why="timed out after ${LIMIT}s"
    elif [ $rc -ne "$want_rc" ]; then
        why="exit $rc, want $want_rc"
    fi
    if [ -z "$why" ] && ! has_line "$T/stderr" "$want_line" "$glob"; then
        why="stderr does not hold the line"
    fi
    if [ -z "$why" ] && [ -e "$out" ]; then
        why="a PNG was written"
    fi
    if [ -z "$why" ]; then
        echo "PASS $name"
    else
        echo "FAIL $name: got $why; stderr: $(oneline "$T/stderr"); want: $want_line${mark:+ [$mark]}"
    fi
done <"$TSV"
if [ "$n" -lt 1 ]; then
    echo "FAIL bad-scene-corpus: no cases read from $TSV"
fi

# ---- good scenes ----------------------------------------------------------------
png_size() { python3 -c 'import struct,sys; d=open(sys.argv[1],"rb").read(24); print("%dx%d" % struct.unpack(">II", d[16:24]) if d[:8] == b"\x89PNG\r\n\x1a\n" else "not-a-png")' "$1"; }
scene_size() { python3 -c 'import json,sys; r=json.load(open(sys.argv[1])).get("render", {}); print("%dx%d" % (r.get("width", 640), r.get("height", 480)))' "$1"; }

# A centred crop of at most 64 x 64 pixels: the whole scene is loaded and
# built, and the crop's rays go through it, at a cost that stays small for
# path-traced scenes with many samples (a busy machine must not time out).
for s in scenes/*.json; do
    name="good-scene $(basename "$s")"
    out="$T/good.png"
    rm -f "$out"
    size=$(scene_size "$s")
    W=${size%x*} H=${size#*x}
    w=$((W < 64 ? W : 64)) h=$((H < 64 ? H : 64))
    region="$(((W - w) / 2)),$(((H - h) / 2)),$w,$h"
    timeout -k 5 300 "$R" "$s" -o "$out" --region "$region" 2>"$T/stderr"
    rc=$?
    if [ $rc -ne 0 ]; then
        echo "FAIL $name: exit $rc (--region $region); stderr: $(oneline "$T/stderr")"
    elif [ ! -s "$out" ]; then
        echo "FAIL $name: no PNG written"
    elif [ "$(png_size "$out")" != "${w}x${h}" ]; then
        echo "FAIL $name: PNG is $(png_size "$out"), want ${w}x${h} (--region $region)"
    elif [ -s "$T/stderr" ]; then
        echo "FAIL $name: unexpected stderr: $(oneline "$T/stderr")"
    else
        echo "PASS $name"
    fi
done

# A small scene for the command-line checks: 64 x 48.
small="$T/small.json"
python3 - "$small" <<'PY'
import json, sys
s = json.load(open("scenes/paper.json"))
s["render"].update(width=64, height=48)
open(sys.argv[1], "w").write(json.dumps(s))
PY

# ---- stdin ------------------------------------------------------------------------
rm -f "$T/file.png" "$T/stdin.png"
"$R" "$small" -o "$T/file.png" 2>"$T/stderr"
rc1=$?
"$R" - -o "$T/stdin.png" <"$small" 2>>"$T/stderr"
rc2=$?
if [ $rc1 -eq 0 ] && [ $rc2 -eq 0 ] && cmp -s "$T/file.png" "$T/stdin.png"; then
    echo "PASS cli-scene-from-stdin"
else
    echo "FAIL cli-scene-from-stdin: exit $rc1/$rc2 or bytes differ; stderr: $(oneline "$T/stderr")"
fi

# A bad scene on stdin is refused like a bad file.
rm -f "$T/x.png"
printf '{"objects": [{"type": "sphere", "radius": -1}]}' | "$R" - -o "$T/x.png" 2>"$T/stderr"
rc=$?
if [ $rc -eq 1 ] && grep -qxF "rayd-render: error: <stdin>: /objects/0/radius: must be > 0" "$T/stderr" && [ ! -e "$T/x.png" ]; then
    echo "PASS cli-bad-scene-from-stdin"
else
    echo "FAIL cli-bad-scene-from-stdin: exit $rc; stderr: $(oneline "$T/stderr")"
fi

# ---- --region errors ------------------------------------------------------------
# region_err NAME REGION EXPECTED-LINE: exit 2, the line on stderr, no PNG.
region_err() {
    local name=$1 region=$2 want=$3 rc
    rm -f "$T/x.png"
    timeout -k 5 60 "$R" "$small" -o "$T/x.png" --region "$region" >/dev/null 2>"$T/stderr"
    rc=$?
    if [ $rc -eq 2 ] && grep -qxF -- "$want" "$T/stderr" && [ ! -e "$T/x.png" ]; then
        echo "PASS $name"
    else
        echo "FAIL $name: --region '$region': exit $rc, png $([ -e "$T/x.png" ] && echo written || echo none); stderr: $(oneline "$T/stderr"); want: $want"
    fi
}
SYNTAX="rayd-render: error: --region takes X,Y,W,H (four integers)"
region_err cli-region-x-past-width 64,0,1,1 "rayd-render: error: --region x: must be in 0..63 (the image is 64 wide)"
region_err cli-region-x-negative -1,0,8,8 "rayd-render: error: --region x: must be in 0..63 (the image is 64 wide)"
region_err cli-region-y-past-height 0,48,1,1 "rayd-render: error: --region y: must be in 0..47 (the image is 48 high)"
region_err cli-region-w-too-wide 60,0,8,8 "rayd-render: error: --region w: must be in 1..4 (x + w may not pass the width 64)"
region_err cli-region-h-too-high 0,40,8,9 "rayd-render: error: --region h: must be in 1..8 (y + h may not pass the height 48)"
region_err cli-region-w-zero 0,0,0,8 "rayd-render: error: --region w: must be in 1..64 (x + w may not pass the width 64)"
region_err cli-region-w-negative 0,0,-8,8 "rayd-render: error: --region w: must be in 1..64 (x + w may not pass the width 64)"
region_err cli-region-empty-at-offset 5,5,0,0 "rayd-render: error: --region needs W and H > 0"
# 0 x 0 at the origin is the core's "whole image": given on the command line
# it is a mistake, not a request for everything.
region_err cli-region-empty-at-origin 0,0,0,0 "rayd-render: error: --region needs W and H > 0"

# Every usage error ends with the pointer to --help, also those the core
# finds once the scene says how big the image is.
for r in 0,0,0,0 0,0,100000,8; do
    "$R" "$small" -o "$T/x.png" --region "$r" >/dev/null 2>"$T/stderr"
    rc=$?
    if [ $rc -eq 2 ] && [ "$(tail -n 1 "$T/stderr")" = "Try 'rayd-render --help'." ]; then
        echo "PASS cli-region-usage-try-line-$r"
    else
        echo "FAIL cli-region-usage-try-line-$r: exit $rc; stderr: $(oneline "$T/stderr")"
    fi
done
region_err cli-region-three-numbers 1,2,3 "$SYNTAX"
region_err cli-region-five-numbers 0,0,8,8,8 "$SYNTAX"
region_err cli-region-letters a,b,c,d "$SYNTAX"
region_err cli-region-hex 0x10,0,1,1 "$SYNTAX"
region_err cli-region-trailing-comma 0,0,8,8, "$SYNTAX"
region_err cli-region-empty "" "$SYNTAX"
# 2^32 does not fit an int: it must be refused, not wrapped to 0.
region_err cli-region-int-overflow 4294967296,0,8,8 "$SYNTAX"

rm -f "$T/x.png"
"$R" "$small" -o "$T/x.png" --region 2>"$T/stderr"
rc=$?
if [ $rc -eq 2 ] && grep -qxF "$SYNTAX" "$T/stderr" && [ ! -e "$T/x.png" ]; then
    echo "PASS cli-region-missing-value"
else
    echo "FAIL cli-region-missing-value: exit $rc; stderr: $(oneline "$T/stderr")"
fi

# A good region still works (and is W x H).
rm -f "$T/x.png"
if "$R" "$small" -o "$T/x.png" --region 60,40,4,8 2>"$T/stderr" && [ "$(png_size "$T/x.png")" = 4x8 ]; then
    echo "PASS cli-region-ok"
else
    echo "FAIL cli-region-ok: stderr: $(oneline "$T/stderr")"
fi

# ---- missing scene file ---------------------------------------------------------
rm -f "$T/x.png"
"$R" "$T/no-such-scene.json" -o "$T/x.png" 2>"$T/stderr"
rc=$?
want="rayd-render: error: cannot open $T/no-such-scene.json: No such file or directory"
if [ $rc -eq 1 ] && grep -qxF -- "$want" "$T/stderr" && [ ! -e "$T/x.png" ]; then
    echo "PASS cli-missing-scene-file"
else
    echo "FAIL cli-missing-scene-file: exit $rc; stderr: $(oneline "$T/stderr")"
fi
exit 0
