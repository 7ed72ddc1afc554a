#!/bin/sh
# rayd-curl.sh SCENE.json OUT.png [SERVER] -- render a scene with nothing but curl.
#
#   programs/curl/rayd-curl.sh scenes/paper.json paper.png http://127.0.0.1:8080
#
# On success writes OUT.png; on a refused scene prints the server's JSON
# error (code, message, JSON Pointer path) and exits 1.  SERVER defaults to
# $RAYD_SERVER or http://127.0.0.1:8080.  A bearer token is read from
# $RAYD_TOKEN_FILE or taken from $RAYD_TOKEN, and passed to curl on its
# standard input, never on its command line (visible in ps).
set -eu
[ $# -ge 2 ] || { echo "usage: $0 SCENE.json OUT.png [SERVER]" >&2; exit 2; }
# curl would send an empty body for a file it cannot read, and the server's
# "unexpected end of input" would hide the real trouble.
[ -f "$1" ] && [ -r "$1" ] || { echo "rayd-curl: error: cannot read $1" >&2; exit 1; }
server=${3:-${RAYD_SERVER:-http://127.0.0.1:8080}}
token=${RAYD_TOKEN:-}
[ -n "${RAYD_TOKEN_FILE:-}" ] && token=$(cat "$RAYD_TOKEN_FILE")
tmp="$2.part"
status=$(printf '%s\n' ${token:+"Authorization: Bearer $token"} |
    curl -sS -o "$tmp" -w '%{http_code}' --data-binary @"$1" \
        -H 'Content-Type: application/json' -H @- "$server/v1/render" 2>"$tmp.err") || status=000
if [ "$status" = 200 ]; then rm -f "$tmp.err"; mv "$tmp" "$2"; exit 0; fi
if [ "$status" = 000 ]; then # no answer at all: say which server and curl's reason
    echo "rayd-curl: error: no answer from $server: $(cat "$tmp.err" 2>/dev/null)" >&2
else
    echo "rayd-curl: HTTP $status: $(cat "$tmp" 2>/dev/null)" >&2
fi
rm -f "$tmp" "$tmp.err"
exit 1
