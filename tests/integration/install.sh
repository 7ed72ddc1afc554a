#!/usr/bin/env bash
# make install and make uninstall, into a scratch DESTDIR, from the build
# tests/run.sh was given (make install copies it; it compiles nothing of the
# programs or of librayd.a).  The installed tree is used as a user would:
#   - the files are exactly those listed, with the soname links;
#   - the installed programs run and render a scene from scenes/;
#   - a C program built with `pkg-config --cflags --libs rayd` alone links the
#     shared library, runs, renders the same bytes as rayd-render and sees
#     the version of the file VERSION; linked with --static flags against
#     librayd.a it does too;
#   - the man pages are found by man; the systemd unit verifies
#     (systemd-analyze, else a SKIP line) with the installed paths, and rayd
#     starts with the environment of the installed environment file;
#   - make uninstall leaves no file, and keeps an edited environment file.
set -u
# rayd-test: alone (runs make in the tree: a stale tree relinks the binaries other tests run)
source "$(dirname "$0")/lib/common.sh"
cd "$RAYD_ROOT"

VERSION=$(cat VERSION)
MAJOR=${VERSION%%.*}
BUILD_REL=$(realpath --relative-to="$RAYD_ROOT" "$RAYD_BUILD")
MAKEVARS=(BUILD="$BUILD_REL")
case $BUILD_REL in
*asan) MAKEVARS+=(SANITIZE=1) ;;
*tsan) MAKEVARS+=(TSAN=1) ;;
esac
D=$T/root
SCENE=scenes/paper.json

# files_under DIR: every file and link below DIR, relative, sorted.
files_under() { (cd "$1" && find . \( -type f -o -type l \) | sed 's|^\./||' | sort); }

# --- make install, PREFIX=/usr -----------------------------------------------
# A dry run first: nothing of the static build may be compiled again.
make -n install DESTDIR="$D" PREFIX=/usr "${MAKEVARS[@]}" >"$T/dry.log" 2>&1
rebuilt=$(grep -E -- " -c [a-z]+/.*-o $BUILD_REL/(core|server|programs)/| -o $BUILD_REL/(rayd|rayd-render|rayd-client) |^ar rcs $BUILD_REL/librayd.a " \
    "$T/dry.log" | head -n 3)
check install-builds-nothing "make install would compile or link again: $rebuilt" [ -z "$rebuilt" ]

if make install DESTDIR="$D" PREFIX=/usr "${MAKEVARS[@]}" >"$T/install.log" 2>&1; then
    pass install-runs
else
    fail install-runs "make install failed: $(tail -n 5 "$T/install.log")"
    exit 1
fi

cat >"$T/want" <<EOF
etc/default/rayd
usr/bin/rayd
usr/bin/rayd-client
usr/bin/rayd-render
usr/include/rayd/rayd.h
usr/lib/librayd.a
usr/lib/librayd.so
usr/lib/librayd.so.$MAJOR
usr/lib/librayd.so.$VERSION
usr/lib/pkgconfig/rayd.pc
usr/lib/systemd/system/rayd.service
usr/share/man/man1/rayd-client.1
usr/share/man/man1/rayd-render.1
usr/share/man/man1/rayd.1
EOF
for f in scenes/*.json scenes/*.hdr; do echo "usr/share/rayd/$f"; done >>"$T/want"
sort -o "$T/want" "$T/want"
files_under "$D" >"$T/got"
check install-tree "the tree differs from the list: $(diff "$T/want" "$T/got" | grep '^[<>]' | tr '\n' ' ')" \
    cmp -s "$T/want" "$T/got"

L=$D/usr/lib
check install-so-links "librayd.so -> $(readlink "$L/librayd.so"), .so.$MAJOR -> $(readlink "$L/librayd.so.$MAJOR")" \
    [ "$(readlink "$L/librayd.so")" = "librayd.so.$MAJOR" -a \
    "$(readlink "$L/librayd.so.$MAJOR")" = "librayd.so.$VERSION" -a -f "$L/librayd.so.$VERSION" ]
soname=$(readelf -d "$L/librayd.so.$VERSION" 2>/dev/null | sed -n 's/.*SONAME.*\[\(.*\)\]/\1/p')
check install-soname "soname is '$soname'" [ "$soname" = "librayd.so.$MAJOR" ]
# Only the public API leaves the shared library.
private=$(nm -D --defined-only "$L/librayd.so.$VERSION" | awk '{print $3}' | grep -v '^rayd_' | head -n 5)
check install-so-exports-api "librayd.so exports non-API symbols: $private" [ -z "$private" ]
check install-header-version "the installed rayd.h does not define RAYD_VERSION \"$VERSION\"" \
    grep -qx "#define RAYD_VERSION \"$VERSION\"" "$D/usr/include/rayd/rayd.h"

# --- the installed programs --------------------------------------------------
# The installed examples render from where they are, the map they name beside them.
check install-scenes-render "$D/usr/share/rayd/scenes/studio.json did not render" \
    "$D/usr/bin/rayd-render" "$D/usr/share/rayd/scenes/studio.json" -o "$T/studio.png" \
    --region 0,0,32,24
check install-render-help "rayd-render --help did not exit 0" \
    "$D/usr/bin/rayd-render" --help >/dev/null
if "$D/usr/bin/rayd-render" "$SCENE" -o "$T/cli.png" 2>"$T/err" && is_png "$T/cli.png" &&
    [ "$(png_size "$T/cli.png")" = 640x480 ]; then
    pass install-render-png
else
    fail install-render-png "the installed rayd-render did not write a 640x480 PNG: $(cat "$T/err")"
fi
check install-rayd-version "rayd --version said '$("$D/usr/bin/rayd" --version 2>&1)'" \
    [ "$("$D/usr/bin/rayd" --version 2>&1)" = "rayd $VERSION" ]
check install-client-help "rayd-client --help did not exit 0" \
    "$D/usr/bin/rayd-client" --help >/dev/null

# --- a program built with pkg-config against the installed library ------------
export PKG_CONFIG_PATH=$L/pkgconfig PKG_CONFIG_SYSROOT_DIR=$D
check install-pc-version "pkg-config --modversion rayd said '$(pkg-config --modversion rayd 2>&1)'" \
    [ "$(pkg-config --modversion rayd 2>&1)" = "$VERSION" ]
# A sanitized librayd needs its runtime in the program too.
san=()
ldd "$L/librayd.so.$VERSION" | grep -q libasan && san=(-fsanitize=address,undefined)
ldd "$L/librayd.so.$VERSION" | grep -q libtsan && san=(-fsanitize=thread)
# shellcheck disable=SC2046 # pkg-config's flags are words
if cc -std=c11 -Wall -Wextra -Werror "${san[@]}" -o "$T/demo" tests/integration/lib/install_demo.c \
    $(pkg-config --cflags --libs rayd) 2>"$T/err"; then
    pass install-pc-compiles
else
    fail install-pc-compiles "$(head -n 5 "$T/err")"
fi
needed=$(readelf -d "$T/demo" 2>/dev/null | grep -c "NEEDED.*\[librayd.so.$MAJOR\]")
check install-pc-links-shared "the program does not need librayd.so.$MAJOR" [ "$needed" = 1 ]
out=$(LD_LIBRARY_PATH=$L "$T/demo" "$SCENE" "$T/api.png" 2>"$T/err")
check install-api-version "the program printed '$out' $(cat "$T/err")" [ "$out" = "$VERSION 640 480" ]
check install-api-same-bytes "the shared library's PNG differs from rayd-render's" \
    cmp -s "$T/api.png" "$T/cli.png"
# shellcheck disable=SC2046
if cc -std=c11 "${san[@]}" -o "$T/demo_static" tests/integration/lib/install_demo.c \
    $(pkg-config --cflags --static --libs rayd | sed 's/-lrayd\b/-l:librayd.a/') 2>"$T/err" &&
    ! readelf -d "$T/demo_static" | grep -q "NEEDED.*librayd" &&
    "$T/demo_static" "$SCENE" "$T/static.png" >/dev/null && cmp -s "$T/static.png" "$T/cli.png"; then
    pass install-pc-static
else
    fail install-pc-static "linking librayd.a by pkg-config --static failed: $(head -n 5 "$T/err")"
fi
unset PKG_CONFIG_PATH PKG_CONFIG_SYSROOT_DIR

# --- man pages, the unit, the environment file --------------------------------
if command -v man >/dev/null 2>&1; then
    for p in rayd rayd-render rayd-client; do
        where=$(man -M "$D/usr/share/man" -w "$p" 2>/dev/null)
        check "install-man-$p" "man -M ... -w $p found '$where'" \
            [ "$where" = "$D/usr/share/man/man1/$p.1" ]
    done
else
    echo "SKIP install-man: man is not installed (the pages are in the tree: install-tree)"
fi

unit=$D/usr/lib/systemd/system/rayd.service
check install-unit-execstart "ExecStart is not /usr/bin/rayd" grep -qx 'ExecStart=/usr/bin/rayd' "$unit"
check install-unit-envfile "EnvironmentFile is not -/etc/default/rayd" \
    grep -qx 'EnvironmentFile=-/etc/default/rayd' "$unit"
if command -v systemd-analyze >/dev/null 2>&1; then
    # The unit as installed, its two paths pointed into the scratch tree.
    sed -e "s|^ExecStart=/usr/bin/|ExecStart=$D/usr/bin/|" \
        -e "s|^EnvironmentFile=-/etc/|EnvironmentFile=-$D/etc/|" "$unit" >"$T/rayd.service"
    if systemd-analyze verify --man=no "$T/rayd.service" >"$T/verify" 2>&1 && [ ! -s "$T/verify" ]; then
        pass install-unit-verifies
    else
        fail install-unit-verifies "$(head -n 5 "$T/verify")"
    fi
    exposure=$(systemd-analyze security --offline=true "$T/rayd.service" 2>/dev/null |
        sed -n 's/.*Overall exposure level for .*: \([0-9.]*\) .*/\1/p')
    if [ -z "$exposure" ]; then
        echo "SKIP install-unit-exposure: this systemd-analyze has no security --offline"
    else
        check install-unit-exposure "exposure level $exposure, want at most 2.0" \
            python3 -c "import sys; sys.exit(float('$exposure') > 2.0)"
    fi
else
    echo "SKIP install-unit-verifies: systemd-analyze is not installed"
fi

# Every variable of the environment file is a rayd option, and rayd starts
# with them (--port 0 wins over its RAYD_PORT, as a flag does).
envfile=$D/etc/default/rayd
unknown=
while IFS='=' read -r name _; do
    "$D/usr/bin/rayd" --help | grep -q "env $name," || unknown="$unknown $name"
done < <(grep -E '^[A-Z_]+=' "$envfile")
check install-envfile-options "not options of rayd:$unknown" [ -z "$unknown" ]
RAYD=$D/usr/bin/rayd
RAYD_WRAP="env $(grep -E '^RAYD_[A-Z_]+=' "$envfile" | tr '\n' ' ') ${RAYD_WRAP:-}"
start_rayd
status=$(req GET /healthz)
stop_rayd TERM
check install-envfile-starts "GET /healthz: $status, exit status $RAYD_RC; $(tail -n 3 "$T/rayd.err")" \
    [ "$status" = 200 -a "$RAYD_RC" = 0 ]

# --- make uninstall -----------------------------------------------------------
if make uninstall DESTDIR="$D" PREFIX=/usr "${MAKEVARS[@]}" >"$T/uninstall.log" 2>&1; then
    left=$(files_under "$D" | tr '\n' ' ')
    check uninstall-leaves-nothing "left behind: $left" [ -z "$left" ]
else
    fail uninstall-leaves-nothing "make uninstall failed: $(tail -n 5 "$T/uninstall.log")"
fi

# An edited environment file survives a new install and the uninstall.
make install DESTDIR="$D" PREFIX=/usr "${MAKEVARS[@]}" >/dev/null 2>&1
echo 'RAYD_THREADS=3' >>"$D/etc/default/rayd"
make install DESTDIR="$D" PREFIX=/usr "${MAKEVARS[@]}" >"$T/install2.log" 2>&1
check install-keeps-edited-envfile "a second make install overwrote the edited file" \
    grep -qx 'RAYD_THREADS=3' "$D/etc/default/rayd"
make uninstall DESTDIR="$D" PREFIX=/usr "${MAKEVARS[@]}" >/dev/null 2>&1
check uninstall-keeps-edited-envfile "left: $(files_under "$D" | tr '\n' ' ')" \
    [ "$(files_under "$D")" = etc/default/rayd ]

# --- the default PREFIX ---------------------------------------------------------
D2=$T/root2
make install DESTDIR="$D2" "${MAKEVARS[@]}" >"$T/install3.log" 2>&1
check install-default-prefix "/usr/local paths: $(files_under "$D2" | grep -v '^usr/local/' | tr '\n' ' ')" \
    [ -z "$(files_under "$D2" | grep -v '^usr/local/')" -a -f "$D2/usr/local/etc/default/rayd" -a \
    -x "$D2/usr/local/bin/rayd" ]
check install-default-unit "the unit does not name /usr/local" \
    grep -qx 'ExecStart=/usr/local/bin/rayd' "$D2/usr/local/lib/systemd/system/rayd.service"
check install-default-pc "rayd.pc's prefix is not /usr/local" \
    grep -qx 'prefix=/usr/local' "$D2/usr/local/lib/pkgconfig/rayd.pc"
make uninstall DESTDIR="$D2" "${MAKEVARS[@]}" >/dev/null 2>&1
check uninstall-default-prefix "left: $(files_under "$D2" | tr '\n' ' ')" [ -z "$(files_under "$D2")" ]

# --- the version's one source ---------------------------------------------------
top=$(sed -n 's/^## \[\([0-9][^]]*\)\].*/\1/p' CHANGELOG.md | head -n 1)
check changelog-version "CHANGELOG.md's first version is '$top', VERSION says $VERSION" [ "$top" = "$VERSION" ]
check license-mit "LICENSE is not the MIT licence of the rayd authors" \
    grep -q 'Copyright (c) 2026 the rayd authors' LICENSE
exit $((NFAIL > 0))
