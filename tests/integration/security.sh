#!/usr/bin/env bash
# security.sh -- --token-file (401 without or with a wrong bearer token on
# every route but /healthz, /readyz, the preview page and OPTIONS), and the --cors-origin allow-list
# with OPTIONS preflight.
source "$(dirname "$0")/lib/common.sh"

scene "$T/s.json" 64 48 1 spheres

# --- without a token everything is open ------------------------------------------------
start_rayd
check open_without_token "status" [ "$(post_json /v1/render "$T/s.json")" = 200 ]
check no_cors_by_default "ACAO sent" bash -c "! curl -s -D - -o /dev/null -H 'Origin: http://a.example' '$URL/healthz' | grep -qi access-control-allow-origin"
check loopback_no_warning "warned on 127.0.0.1" bash -c "! grep -q WARNING '$T/rayd.err'"
stop_rayd TERM

# --- with a token -------------------------------------------------------------------------
printf 's3cret-token\n' >"$T/token"
start_rayd --token-file "$T/token" --cors-origin "http://a.example, http://b.example"
code=$(post_json /v1/render "$T/s.json")
check auth_missing_401 "status $code" err_is "$T/body" 401 unauthorized
check auth_www_authenticate "$(header WWW-Authenticate)" bash -c "[[ '$(header WWW-Authenticate)' == Bearer* ]]"
code=$(post_json /v1/render "$T/s.json" -H 'Authorization: Bearer wrong')
check auth_wrong_401 "status $code" err_is "$T/body" 401 unauthorized
code=$(post_json /v1/render "$T/s.json" -H 'Authorization: Bearer s3cret-token-and-more')
check auth_prefix_401 "status $code" err_is "$T/body" 401 unauthorized
code=$(post_json /v1/render "$T/s.json" -H 'Authorization: Bearer s3cret-toke')
check auth_short_401 "status $code" err_is "$T/body" 401 unauthorized
code=$(post_json /v1/render "$T/s.json" -H 'Authorization: Bearer s3cret-token')
check auth_right_200 "status $code" bash -c "[ $code = 200 ] && head -c 4 '$T/body' | grep -q PNG"
for p in /metrics /v1/scenes/0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef/image.png /v1/jobs/0123456789abcdef0123456789abcdef /nope; do
    code=$(req GET "$p")
    check "auth_required_${p//[\/]/_}" "status $code" [ "$code" = 401 ]
done
# the token is checked with the headers, before the body: a client without it
# is refused at once (never told "100 Continue", never read and kept up to
# --max-body). The client sends headers only and reads the first answer; a
# server that waited for the body would answer 100 or nothing.
first_answer() { # AUTH-HEADER (or ""): the status line rayd sends to a 1 MB POST's headers
    python3 - "$PORT" "$1" <<'PY'
import socket, sys
s = socket.create_connection(("127.0.0.1", int(sys.argv[1])))
s.sendall(b"POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
          b"Content-Length: 1000000\r\nExpect: 100-continue\r\n" +
          (sys.argv[2].encode() + b"\r\n" if sys.argv[2] else b"") + b"\r\n")
s.settimeout(20)
try:
    print(s.recv(200).split(b"\r\n")[0].decode())
except OSError as e:
    print("no answer:", e)
PY
}
line=$(first_answer "")
check auth_before_body "first answer '$line'" [ "$line" = "HTTP/1.1 401 Unauthorized" ]
line=$(first_answer "Authorization: Bearer wrong")
check auth_wrong_before_body "first answer '$line'" [ "$line" = "HTTP/1.1 401 Unauthorized" ]
line=$(first_answer "Authorization: Bearer s3cret-token")
check auth_right_continue "first answer '$line'" [ "$line" = "HTTP/1.1 100 Continue" ]
# a request without a body is refused as before: its connection stays open
got=$(raw_answers "GET /metrics HTTP/1.1\r\nHost: x\r\n\r\nGET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
check auth_401_keeps_connection "answers '$got'" [ "$got" = "HTTP/1.1 401 HTTP/1.1 200" ]
# the preview's static files open without a token (the page then sends the token it is given)
check auth_page_open "status" [ "$(req GET /)" = 200 ]
check auth_page_asset_open "status" [ "$(req GET /app.js)" = 200 ]
check auth_page_post_closed "status" [ "$(req POST /)" = 401 ]
check auth_healthz_open "status" [ "$(req GET /healthz)" = 200 ]
check auth_readyz_open "status" [ "$(req GET /readyz)" = 200 ]
AUTH=(-H 'Authorization: Bearer s3cret-token')
check auth_metrics_with_token "no metrics" [ -n "$(metric rayd_workers)" ]
check auth_rejections_counted "rejections{unauthorized} $(metric 'rayd_rejections_total{reason="unauthorized"}')" \
    [ "$(metric 'rayd_rejections_total{reason="unauthorized"}')" -ge 7 ]

# --- CORS -------------------------------------------------------------------------------------
code=$(req OPTIONS /v1/render -H 'Origin: http://b.example' -H 'Access-Control-Request-Method: POST' \
    -H 'Access-Control-Request-Headers: content-type, authorization')
check cors_preflight_204 "status $code" [ "$code" = 204 ]
check cors_preflight_origin "$(header Access-Control-Allow-Origin)" [ "$(header Access-Control-Allow-Origin)" = http://b.example ]
check cors_preflight_methods "$(header Access-Control-Allow-Methods)" bash -c "[[ '$(header Access-Control-Allow-Methods)' == *POST* ]]"
check cors_preflight_headers "$(header Access-Control-Allow-Headers)" bash -c "[[ '$(header Access-Control-Allow-Headers)' == *Authorization* ]]"
code=$(req OPTIONS /v1/render -H 'Origin: http://evil.example' -H 'Access-Control-Request-Method: POST')
check cors_other_origin_refused "ACAO '$(header Access-Control-Allow-Origin)'" [ -z "$(header Access-Control-Allow-Origin)" ]
code=$(post_json /v1/render "$T/s.json" -H 'Authorization: Bearer s3cret-token' -H 'Origin: http://a.example')
check cors_actual_request "status $code, ACAO '$(header Access-Control-Allow-Origin)'" \
    bash -c "[ $code = 200 ] && [ '$(header Access-Control-Allow-Origin)' = http://a.example ]"
code=$(req OPTIONS /nope -H 'Origin: http://a.example')
check options_unknown_404 "status $code" [ "$code" = 404 ]
stop_rayd TERM
check exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]

"$RAYD" --token-file "$T/missing-file" --port 0 >/dev/null 2>&1
check missing_token_file_fails "rayd started without its token file" [ $? -ne 0 ]

# --- a token file that cannot be a token is refused at start -------------------------------
# A NUL byte once made every request 401, a heap overflow in the compare and
# an abort on SIGTERM; a token over 4,095 bytes was cut silently.  Each is
# refused with exit status 1 and a line naming the file and the problem; the
# process never listens.
token_refused() { # NAME WHAT: rayd --token-file $T/NAME must exit 1 saying WHAT
    local out rc
    out=$(timeout 20 "$RAYD" --bind 127.0.0.1 --port 0 --token-file "$T/$1" 2>&1 </dev/null)
    rc=$?
    [ "$rc" = 1 ] && [[ $out == *"--token-file $T/$1 $2"* ]] && [[ $out != *listening* ]] ||
        { echo "  rc $rc: $out" >&2; return 1; }
}
printf 'abc\0def\n' >"$T/tok-nul"
check token_nul_refused "started or said something else" token_refused tok-nul "holds a NUL byte (byte 4"
printf 'abc\001def\n' >"$T/tok-ctrl"
check token_control_refused "started or said something else" token_refused tok-ctrl "holds a control character"
printf 'abc\tdef\n' >"$T/tok-tab"
check token_tab_refused "started or said something else" token_refused tok-tab "holds a control character"
head -c 4097 /dev/zero | tr '\0' a >"$T/tok-long"
check token_over_4096_refused "started or said something else" token_refused tok-long "holds a token over 4096 bytes"
head -c 100000 /dev/zero | tr '\0' a >"$T/tok-huge"
check token_huge_refused "started or said something else" token_refused tok-huge "holds a token over 4096 bytes"
printf ' \r\n\n' >"$T/tok-blank"
check token_blank_refused "started or said something else" token_refused tok-blank "is empty"
# the longest token there may be, with blanks around it, is used whole: one
# byte more or less is refused
head -c 4096 /dev/zero | tr '\0' b >"$T/tok-max"
printf '  %s \n' "$(cat "$T/tok-max")" >"$T/tok-max-padded"
start_rayd --token-file "$T/tok-max-padded"
code=$(req GET /metrics -H "Authorization: Bearer $(cat "$T/tok-max")")
check token_4096_whole_200 "status $code" [ "$code" = 200 ]
code=$(req GET /metrics -H "Authorization: Bearer $(head -c 4095 "$T/tok-max")")
check token_4096_shorter_401 "status $code" [ "$code" = 401 ]
code=$(req GET /metrics -H "Authorization: Bearer $(cat "$T/tok-max")b")
check token_4096_longer_401 "status $code" [ "$code" = 401 ]
stop_rayd TERM
check token_4096_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- HTTPS with libmicrohttpd's TLS ---------------------------------------------------------
if command -v openssl >/dev/null; then
    openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=127.0.0.1 \
        -addext subjectAltName=IP:127.0.0.1 -keyout "$T/key.pem" -out "$T/cert.pem" >/dev/null 2>&1
    start_rayd --tls-cert "$T/cert.pem" --tls-key "$T/key.pem"
    check tls_listening_https "URL $URL" bash -c "[[ '$URL' == https://* ]]"
    code=$(req GET /healthz --cacert "$T/cert.pem")
    check tls_healthz "status $code" [ "$code" = 200 ]
    code=$(post_json /v1/render "$T/s.json" --cacert "$T/cert.pem")
    check tls_render "status $code" bash -c "[ $code = 200 ] && head -c 4 '$T/body' | grep -q PNG"
    code=$(curl -s -m 5 -o /dev/null -w '%{http_code}' "http://127.0.0.1:$PORT/healthz")
    check tls_plain_http_refused "status $code" [ "$code" != 200 ]
    code=$(req GET /healthz --cacert "$T/cert.pem")
    check tls_alive_after_plain "status $code" [ "$code" = 200 ]
    stop_rayd TERM
    check tls_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
    "$RAYD" --port 0 --tls-cert "$T/cert.pem" >/dev/null 2>&1
    check tls_cert_without_key_fails "rayd started" [ $? -ne 0 ]
    "$RAYD" --port 0 --tls-cert "$T/missing.pem" --tls-key "$T/key.pem" >/dev/null 2>&1
    check tls_missing_cert_fails "rayd started" [ $? -ne 0 ]
else
    echo "SKIP tls: no openssl command"
fi
