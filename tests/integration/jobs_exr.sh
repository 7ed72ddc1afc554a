#!/usr/bin/env bash
# jobs_exr.sh -- HDR out of jobs: POST /v1/jobs?format=exr keeps, beside the
# 8-bit PNG, the OpenEXR of the job's image (GET /v1/jobs/{id}/image.exr) and
# of a progressive job's latest passes (?pass=K).  Each EXR must be byte for
# byte POST /v1/render?format=exr of the same scene with that pass's samples
# (and rayd-render's file), the PNG as before; and every refusal is the
# API's: 404 job_unknown, 202 while not ready, 409 not_exr for a job created
# without format=exr, 409 job_canceled, 410 pass_gone, 400 naming pass or
# format, 405 for a wrong method.  Work in flight is held by the test gate.
source "$(dirname "$0")/lib/common.sh"

start_rayd --threads 2 --test-gate open
HDR="$RAYD_BUILD/tests/tools/hdrcheck"
# 128x64, two 64x64 tiles a pass; passes of 1, 2 and 4 samples
for n in 1 2 4; do
    scene "$T/p$n.json" 128 64 $n cornell
    code=$(post_json "/v1/render?format=exr" "$T/p$n.json")
    cp "$T/body" "$T/ref$n.exr"
    check "ref_${n}_exr" "status $code" [ "$code" = 200 ]
    code=$(post_json /v1/render "$T/p$n.json")
    cp "$T/body" "$T/ref$n.png"
    check "ref_${n}_png" "status $code" [ "$code" = 200 ]
done
"$RENDER" "$T/p4.json" -o "$T/cli4.exr" --threads 1
check ref_exr_is_cli "POST /v1/render?format=exr differs from rayd-render" cmp -s "$T/ref4.exr" "$T/cli4.exr"

# id_of: the job id of the answer in $T/body
id_of() { jfield "$T/body" id; }
# answer_is STATUS CODE: the last request's status ($code) is STATUS and its
# body the API's JSON error CODE
answer_is() { [ "$code" = "$1" ] && err_is "$T/body" "$1" "$2"; }
# param_is STATUS CODE PARAM: answer_is, and the error names PARAM
param_is() { answer_is "$1" "$2" && [ "$(json "$T/body" 'j["error"]["parameter"]')" = "$3" ]; }

# --- a plain job ------------------------------------------------------------------------
code=$(post_json "/v1/jobs?format=exr" "$T/p4.json")
id=$(id_of)
check plain_post_202 "status $code $(head -c 300 "$T/body")" [ "$code" = 202 ]
check plain_post_exr_url "$(head -c 400 "$T/body")" \
    [ "$(jfield "$T/body" exr_url)" = "/v1/jobs/$id/image.exr" ]
wait_until 60 job_state_is "$id" succeeded
check plain_status_exr_url "$(head -c 600 "$T/body")" \
    [ "$(jfield "$T/body" exr_url)" = "/v1/jobs/$id/image.exr" ]
code=$(req GET "/v1/jobs/$id/image.exr")
cp "$T/body" "$T/plain.exr"
check plain_exr_200 "status $code, type $(header Content-Type)" \
    bash -c "[ $code = 200 ] && [ '$(header Content-Type)' = image/x-exr ]"
check plain_exr_equals_render "differs from POST /v1/render?format=exr" cmp -s "$T/plain.exr" "$T/ref4.exr"
check plain_exr_headers "Cache-Control $(header Cache-Control), X-Rayd-Version $(header X-Rayd-Version)" \
    bash -c "[ '$(header Cache-Control)' = 'private, max-age=3600' ] && [ -n '$(header X-Rayd-Version)' ]"
if [ -x "$HDR" ]; then
    check plain_exr_values "$("$HDR" "$T/ref4.png" "$T/plain.exr" 2>&1)" "$HDR" "$T/ref4.png" "$T/plain.exr"
fi
code=$(req GET "/v1/jobs/$id/image.png")
check plain_png_unchanged "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/ref4.png'"
code=$(req HEAD "/v1/jobs/$id/image.exr" -I)
check plain_exr_head "status $code" [ "$code" = 200 ]

# a region: the crop POST /v1/render gives for it
code=$(post_json "/v1/render?x=10&y=5&w=70&h=40&format=exr" "$T/p4.json")
cp "$T/body" "$T/reg.exr"
code=$(post_json "/v1/jobs?x=10&y=5&w=70&h=40&format=exr" "$T/p4.json")
id=$(id_of)
wait_until 60 job_state_is "$id" succeeded
code=$(req GET "/v1/jobs/$id/image.exr")
check region_exr_equals_render "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/reg.exr'"

# a job without format=exr keeps none, and says so; its JSON has no exr_url
code=$(post_json /v1/jobs "$T/p4.json")
plain=$(id_of)
check no_exr_url_without_format "$(head -c 400 "$T/body")" bash -c "! grep -q exr_url '$T/body'"
wait_until 60 job_state_is "$plain" succeeded
code=$(req GET "/v1/jobs/$plain/image.exr")
check not_exr_409 "status $code $(head -c 300 "$T/body")" answer_is 409 not_exr
code=$(post_json "/v1/jobs?format=png" "$T/p4.json")
check format_png_is_plain "status $code $(head -c 300 "$T/body")" \
    bash -c "[ $code = 202 ] && ! grep -q exr_url '$T/body'"

# --- a progressive job, held pass by pass ----------------------------------------------
gate 0
code=$(post_json "/v1/jobs?progressive=1&format=exr" "$T/p4.json")
id=$(id_of)
check prog_post_202 "status $code" [ "$code" = 202 ]
code=$(req GET "/v1/jobs/$id/image.exr")
check prog_exr_202_before_a_pass "status $code, Retry-After $(header Retry-After)" \
    bash -c "[ $code = 202 ] && [ '$(header Retry-After)' = 1 ] && [ '$(jfield "$T/body" state)' = queued ]"
gate 2 # pass 1's two tiles
wait_until 60 job_is "$id" done 1
wait_until 30 gate_is held 2 # pass 2 waits at the gate
code=$(req GET "/v1/jobs/$id/image.exr")
check prog_latest_exr_while_running \
    "status $code, X-Rayd-Pass $(header X-Rayd-Pass), Cache-Control $(header Cache-Control)" \
    bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Pass)' = 1/3 ] && [ '$(header Cache-Control)' = no-store ] && cmp -s '$T/body' '$T/ref1.exr'"
code=$(req GET "/v1/jobs/$id/image.exr?pass=1")
check prog_pass1_exr "status $code, X-Rayd-Samples $(header X-Rayd-Samples)" \
    bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Samples)' = 1 ] && cmp -s '$T/body' '$T/ref1.exr'"
code=$(req GET "/v1/jobs/$id/image.exr?pass=2")
check prog_pass2_not_yet_202 "status $code" bash -c "[ $code = 202 ] && [ '$(jfield "$T/body" state)' = running ]"
req GET "/v1/jobs/$id" >/dev/null
check prog_status_exr_url "$(head -c 800 "$T/body")" \
    bash -c "grep -q '\"exr_url\":\"/v1/jobs/$id/image.exr?pass=1\"' '$T/body'"
gate open
wait_until 60 job_state_is "$id" succeeded
for k in 2 3; do
    n=$((k == 2 ? 2 : 4))
    code=$(req GET "/v1/jobs/$id/image.exr?pass=$k")
    check "prog_pass${k}_exr_equals_render_${n}" "status $code, X-Rayd-Pass $(header X-Rayd-Pass)" \
        bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Pass)' = $k/3 ] && cmp -s '$T/body' '$T/ref$n.exr'"
done
code=$(req GET "/v1/jobs/$id/image.exr")
check prog_final_exr "status $code, X-Rayd-Pass $(header X-Rayd-Pass)" \
    bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Pass)' = 3/3 ] && cmp -s '$T/body' '$T/ref4.exr'"
code=$(req GET "/v1/jobs/$id/image.png")
check prog_final_png "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/ref4.png'"
# the latest two passes' EXRs are kept, the latest four PNGs
code=$(req GET "/v1/jobs/$id/image.exr?pass=1")
check prog_old_exr_410 "status $code $(head -c 300 "$T/body")" \
    param_is 410 pass_gone pass
code=$(req GET "/v1/jobs/$id/image.png?pass=1")
check prog_old_png_kept "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/ref1.png'"

# a client stop after pass 1: that pass is the job's EXR
gate 0
code=$(post_json "/v1/jobs?progressive=1&format=exr" "$T/p4.json")
id=$(id_of)
gate 2
wait_until 60 job_is "$id" done 1
code=$(req POST "/v1/jobs/$id/stop")
check prog_stop_200 "status $code" [ "$code" = 200 ]
code=$(req GET "/v1/jobs/$id/image.exr")
check prog_stop_keeps_pass1_exr "status $code, X-Rayd-Pass $(header X-Rayd-Pass)" \
    bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Pass)' = 1/3 ] && cmp -s '$T/body' '$T/ref1.exr'"

# --- errors -----------------------------------------------------------------------------
# cancelled while held: 409 job_canceled, as image.png
code=$(post_json "/v1/jobs?format=exr" "$T/p4.json")
id=$(id_of)
req DELETE "/v1/jobs/$id" >/dev/null
code=$(req GET "/v1/jobs/$id/image.exr")
check canceled_409 "status $code $(head -c 300 "$T/body")" answer_is 409 job_canceled
gate open
code=$(req GET "/v1/jobs/0123456789abcdef0123456789abcdef/image.exr")
check unknown_job_404 "status $code" answer_is 404 job_unknown
code=$(req GET "/v1/jobs/nope/image.exr")
check malformed_id_404 "status $code" answer_is 404 job_unknown
code=$(post_json "/v1/jobs?progressive=1&format=exr" "$T/p4.json")
id=$(id_of)
wait_until 60 job_state_is "$id" succeeded
for p in 0 4 x 1.0 %2B1; do
    code=$(req GET "/v1/jobs/$id/image.exr?pass=$p")
    check "bad_pass_$p" "status $code $(head -c 300 "$T/body")" param_is 400 bad_parameter pass
done
code=$(req GET "/v1/jobs/$id/image.exr?pass=1&pass=2")
check pass_twice_400 "status $code" param_is 400 bad_parameter pass
code=$(req GET "/v1/jobs/$plain/image.exr?pass=1")
check pass_of_plain_job_400 "status $code $(head -c 300 "$T/body")" param_is 400 bad_parameter pass
code=$(req GET "/v1/jobs/$id/image.exr?format=exr")
check exr_route_refuses_format "status $code $(head -c 300 "$T/body")" param_is 400 bad_parameter format
code=$(req POST "/v1/jobs/$id/image.exr")
check exr_post_405 "status $code, Allow $(header Allow)" \
    bash -c "[ $code = 405 ] && grep -qi '^Allow:.*GET' '$T/headers'"
check exr_post_405_body "$(head -c 300 "$T/body")" answer_is 405 method_not_allowed
for f in png16 sums jpeg; do
    code=$(post_json "/v1/jobs?format=$f" "$T/p4.json")
    check "job_format_${f}_400" "status $code $(head -c 300 "$T/body")" param_is 400 bad_parameter format
done
code=$(post_json "/v1/jobs?format=exr&format=exr" "$T/p4.json")
check job_format_twice_400 "status $code" param_is 400 bad_parameter format

stop_rayd TERM
check stopped_cleanly "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
exit 0
