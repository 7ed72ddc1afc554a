#!/bin/sh
# rayd-curl.sh SCENE.json OUT.png [SERVER] -- render a scene with nothing but curl.
#
#   clients/rayd-curl.sh scenes/paper.json paper.png http://127.0.0.1:8080
#
# On success writes OUT.png; on a refused scene prints the server's JSON
# error (code, message, JSON Pointer path) and exits 1.  RAYD_TOKEN, if
# set, is sent as the bearer token.
set -eu
[ $# -ge 2 ] || { echo "usage: $0 SCENE.json OUT.png [SERVER]" >&2; exit 2; }
server=${3:-${RAYD_SERVER:-http://127.0.0.1:8080}}
tmp="$2.part"
status=$(curl -sS -o "$tmp" -w '%{http_code}' --data-binary @"$1" \
    -H 'Content-Type: application/json' ${RAYD_TOKEN:+-H "Authorization: Bearer $RAYD_TOKEN"} \
    "$server/v1/render")
if [ "$status" = 200 ]; then mv "$tmp" "$2"; exit 0; fi
echo "rayd-curl: HTTP $status: $(cat "$tmp")" >&2
rm -f "$tmp"
exit 1
