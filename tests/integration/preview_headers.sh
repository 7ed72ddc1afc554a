#!/usr/bin/env bash
# preview_headers.sh -- the browser preview (GET / and the files beside it)
# is served with the headers that keep other sites out of it: a
# Content-Security-Policy with frame-ancestors 'none', X-Frame-Options: DENY,
# Referrer-Policy, Cross-Origin-Opener-Policy and -Resource-Policy, on GET
# and HEAD, with and without --token-file.  The page itself has nothing the
# policy would refuse: no inline script, style or event handler.  The API's
# answers are not the page's and carry none of it.  (Finding 9 of issue 39:
# a page elsewhere framed the preview with a #scene= link and made it render
# with the user's token; tests/browser/preview.sh checks the page's side.)
source "$(dirname "$0")/lib/common.sh"

# the files the page is made of: every embedded one (server/web/*, examples.js)
FILES="/ /examples.js"
for f in "$RAYD_ROOT"/server/web/*; do FILES="$FILES /$(basename "$f")"; done

# has_directive CSP DIRECTIVE: DIRECTIVE is one of the ;-separated items of CSP
has_directive() {
    local item
    IFS=';' read -ra items <<<"$1"
    for item in "${items[@]}"; do
        item=${item#"${item%%[! ]*}"} # leading spaces
        [ "${item%"${item##*[! ]}"}" = "$2" ] && return 0
    done
    return 1
}

# check_headers NAME METHOD PATH [CURL ARGS]: one case per file and method
check_headers() {
    local name=$1 method=$2 path=$3; shift 3
    local code why= d csp
    code=$(req "$method" "$path" "$@")
    [ "$code" = 200 ] || why="status $code"
    csp=$(header Content-Security-Policy)
    for d in "default-src 'self'" "script-src 'self'" "style-src 'self'" "img-src 'self' blob:" \
        "connect-src 'self'" "object-src 'none'" "frame-ancestors 'none'" "base-uri 'none'" \
        "form-action 'none'"; do
        has_directive "$csp" "$d" || why="$why; no \"$d\" in CSP \"$csp\""
    done
    case $csp in *unsafe-inline* | *unsafe-eval* | *'*'*) why="$why; CSP allows too much: $csp" ;; esac
    [ "$(header X-Frame-Options)" = DENY ] || why="$why; X-Frame-Options '$(header X-Frame-Options)'"
    [ "$(header Referrer-Policy)" = no-referrer ] || why="$why; Referrer-Policy '$(header Referrer-Policy)'"
    [ "$(header Cross-Origin-Opener-Policy)" = same-origin ] ||
        why="$why; Cross-Origin-Opener-Policy '$(header Cross-Origin-Opener-Policy)'"
    [ "$(header Cross-Origin-Resource-Policy)" = same-origin ] ||
        why="$why; Cross-Origin-Resource-Policy '$(header Cross-Origin-Resource-Policy)'"
    [ "$(grep -ci '^Content-Security-Policy:' "$T/headers")" = 1 ] || why="$why; not one CSP header"
    if [ -z "$why" ]; then pass "$name"; else fail "$name" "${why#; }"; fi
}

start_rayd --threads 1
for p in $FILES; do
    n=${p#/}
    check_headers "get_${n:-root}" GET "$p"
done
check_headers head_root HEAD / -I # -I: no body to wait for
check_headers head_app_js HEAD /app.js -I

# the page has nothing the policy refuses: every script a file, no <style>,
# no style="..." or on...="..." attribute, no javascript: URL
req GET / >/dev/null
inline=$(python3 - "$T/body" <<'PY'
import re, sys
html = open(sys.argv[1], encoding="utf-8").read()
bad = []
for m in re.finditer(r"<script\b[^>]*>", html, re.I):
    if not re.search(r"\bsrc\s*=", m.group(0), re.I):
        bad.append(m.group(0))
bad += re.findall(r"<style\b", html, re.I)
bad += re.findall(r"<[^>]*\s(?:style|on[a-z]+)\s*=[^>]*>", html, re.I)
bad += re.findall(r"javascript:", html, re.I)
print(" | ".join(b[:60] for b in bad))
PY
)
check page_has_no_inline_code "inline: $inline" [ -z "$inline" ]

# the API's answers are not a page: none of the page's headers
req GET /healthz >/dev/null
check api_without_page_headers "CSP '$(header Content-Security-Policy)' on /healthz" \
    [ -z "$(header Content-Security-Policy)" ]
stop_rayd
[ "$RAYD_RC" = 0 ] || fail rayd_exit "rayd exited with $RAYD_RC"

# with --token-file the page stays open (a browser cannot send a token to
# open it) and keeps its headers
printf 'preview-headers-token\n' >"$T/token"
start_rayd --threads 1 --token-file "$T/token"
check_headers token_get_root GET /
check_headers token_get_app_js GET /app.js
stop_rayd
[ "$RAYD_RC" = 0 ] || fail rayd_token_exit "rayd exited with $RAYD_RC"
exit 0
