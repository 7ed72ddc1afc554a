# browser.sh -- what the browser tests' scripts (tests/browser/*.sh) share,
# sourced after common.sh: where Chromium and the test's Node files are,
# and the check that they are there.
HERE=$RAYD_ROOT/tests/browser
CHROMIUM=${CHROMIUM:-/usr/bin/chromium}

# browser_need NAME [MISSING]: fails the case NAME and ends the script when
# Chromium, Node or playwright-core is missing (with MISSING, what the
# script itself found missing), so a test without its browser never passes.
browser_need() {
    local missing=${2:-}
    [ -x "$CHROMIUM" ] || missing="$missing chromium ($CHROMIUM; make test-deps installs Debian's chromium)"
    command -v node >/dev/null 2>&1 || missing="$missing node (Node.js)"
    [ -f "$HERE/node_modules/playwright-core/package.json" ] ||
        missing="$missing playwright-core (make test runs npm ci in tests/browser)"
    if [ -n "$missing" ]; then
        fail "$1" "missing:$missing"
        exit 1
    fi
}
