#!/usr/bin/env bash
# The man pages (docs/man/*.1) against the programs they describe: every long
# option a program's --help prints appears in its page, so the two cannot
# drift apart; and each page renders without a single warning.
#
# The options are looked for in the page as man shows it (man -l, or groff
# alone), as whole words; with neither installed, in the roff source with its
# \- read as -, and the rendering is a SKIP line.
set -u
source "$(dirname "$0")/lib/common.sh"
cd "$RAYD_ROOT"

renderer=
if command -v man >/dev/null 2>&1 && command -v groff >/dev/null 2>&1; then
    renderer=man
elif command -v groff >/dev/null 2>&1; then
    renderer=groff
fi

# page_text PAGE: the page as plain ASCII text on stdout.
page_text() {
    case $renderer in
    man) LC_ALL=C MANWIDTH=100 man -l "$1" 2>/dev/null | col -b ;;
    groff) groff -man -Tascii -P-cbou "$1" 2>/dev/null ;;
    *) sed -e 's/\\-/-/g' "$1" ;;
    esac
}

# help_options PROGRAM: the long options its --help offers, one a line: those
# of the usage lines ("[--format F]", "--server URL") and those that open an
# option line ("  -o, --output F"), not the words of its prose
# ("'--opt value' or '--opt=value'").
help_options() {
    "$RAYD_BUILD/$1" --help 2>&1 |
        sed -nE -e '/^ *(usage:|rayd)/,/^$/p' -e 's/^ +(-[a-zA-Z], )?(--[a-z0-9][a-z0-9-]*).*/\2/p' |
        grep -oE -- '(^|[[ |])--[a-z0-9][a-z0-9-]*' | grep -oE -- '--[a-z0-9-]+' | sort -u
}

for prog in rayd rayd-render rayd-client; do
    page=docs/man/$prog.1
    if [ ! -f "$page" ]; then
        fail "man-$prog-exists" "$page is missing"
        continue
    fi
    pass "man-$prog-exists"

    opts=$(help_options "$prog")
    # A help that lists no options means the extraction broke, not a match.
    if [ "$(printf '%s\n' "$opts" | grep -c -- '^--')" -lt 3 ]; then
        fail "man-$prog-options" "$prog --help printed fewer than 3 long options: $opts"
        continue
    fi
    text=$(page_text "$page")
    missing=
    for o in $opts; do
        grep -qE -- "(^|[^a-z0-9-])$o([^a-z0-9-]|\$)" <<<"$text" || missing="$missing $o"
    done
    if [ -z "$missing" ]; then
        pass "man-$prog-options"
    else
        fail "man-$prog-options" "$page lacks options its --help prints:$missing"
    fi

    if [ -z "$renderer" ]; then
        echo "SKIP man-$prog-renders: neither man nor groff is installed"
        continue
    fi
    # -ww: every groff warning; man -l --warnings runs the same formatter.
    {
        groff -man -Tascii -ww -z "$page"
        [ "$renderer" = man ] && LC_ALL=C MANWIDTH=100 man --warnings -l "$page" >/dev/null
    } 2>"$T/warn"
    warn=$(tr '\n' ' ' <"$T/warn")
    if [ -z "$warn" ] && [ -n "$text" ]; then
        pass "man-$prog-renders"
    else
        fail "man-$prog-renders" "${warn:-empty output}"
    fi
    # The NAME line is what whatis/apropos index.
    if grep -qE "^ *$prog - " <<<"$text"; then
        pass "man-$prog-name"
    else
        fail "man-$prog-name" "no '$prog - ...' line in NAME"
    fi
done
exit $((NFAIL > 0))
