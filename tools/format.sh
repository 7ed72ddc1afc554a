#!/bin/sh
# tools/format.sh [--check] -- clang-format every C file of the tree.
#
# The files: every .c and .h git knows under the tree's C folders, found
# by pattern, not by a list, so a folder moved or added is still covered
# (build/, node_modules/ and generated files are never tracked).  The style
# is the root .clang-format, the only one.
#   tools/format.sh          rewrites the files in place (make format)
#   tools/format.sh --check  changes nothing; lists each file that is not
#                            clean and exits 1 if any (make format-check)
set -eu
cd "$(dirname "$0")/.."
CLANG_FORMAT=${CLANG_FORMAT:-clang-format}
files=$(git ls-files '*.c' '*.h')
[ -n "$files" ] || { echo "format: no C files found" >&2; exit 1; }
if [ "${1:-}" = --check ]; then
    bad=$(printf '%s\n' $files | xargs -P "$(nproc 2>/dev/null || echo 2)" -n 8 sh -c '
        for f; do "$0" --dry-run -Werror "$f" >/dev/null 2>&1 || echo "$f"; done' "$CLANG_FORMAT")
    if [ -n "$bad" ]; then
        n=$(printf '%s\n' "$bad" | wc -l)
        printf '%s\n' "$bad" | sort
        echo "format-check: $n of $(printf '%s\n' $files | wc -l) files are not clean (make format)"
        exit 1
    fi
    echo "format-check: all $(printf '%s\n' $files | wc -l) files clean"
else
    printf '%s\n' $files | xargs -P "$(nproc 2>/dev/null || echo 2)" -n 8 "$CLANG_FORMAT" -i
fi
