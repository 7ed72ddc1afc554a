#!/usr/bin/env bash
# offload.sh -- scenes are parsed on a pool of their own, never on the HTTP
# threads (server/work/compile.c).  With the test gate holding every parse
# (POST /v1/test/gate?parses=0), the scenes posted stay queued while
# /healthz, /readyz and /metrics answer at once; --parse-queue scenes wait
# and one more is refused 503 queue_full with a Retry-After; the same body
# posted three times at once is parsed once and all three get the scene (or
# all the same error); a client that hangs up while its scene waits leaves
# the parse to finish and the scene cached; a drain answers a held parse's
# request 503 draining and exits 0.  And a scene naming one --asset-dir file
# 3,000 times costs one stat per cached GET of its image, not 3,000
# (rayd_scene_file_checks_total).
source "$(dirname "$0")/lib/common.sh"

AUTH=()
metric() { curl -s -m 30 "$URL/metrics" | sed -n "s/^$1 \([0-9.e+]*\)\$/\1/p"; }
parse_gate() {
    curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?parses=$1" -w '%{http_code}'
}
# scene OUT TAG: a small scene whose bytes (and id) differ by TAG
scene() {
    printf '{"render":{"width":16,"height":12},"objects":[{"type":"sphere","center":[0,0,-3],"radius":%s}]}' \
        "$2" >"$1"
}
# post_bg NAME FILE [CURL ARGS]: POST /v1/scenes of FILE in the background:
# status in $T/NAME.code, body in $T/NAME.body
post_bg() {
    local name=$1 file=$2; shift 2
    curl -s -m 300 -o "$T/$name.body" -w '%{http_code}' -H 'Content-Type: application/json' \
        --data-binary @"$file" "$@" "$URL/v1/scenes" >"$T/$name.code" 2>/dev/null &
    PIDS+=($!)
}
done_code() { [ -s "$T/$1.code" ]; }
code_of() { cat "$T/$1.code" 2>/dev/null; }
# timed PATH: the seconds GET PATH took, its status after a space
timed() { curl -s -m 30 -o /dev/null -w '%{time_total} %{http_code}' "$URL$1"; }
under() { python3 -c 'import sys; sys.exit(0 if float(sys.argv[1]) < float(sys.argv[2]) else 1)' "$1" "$2"; }

start_rayd --test-gate open --parse-threads 1 --parse-queue 2

# --- parses held: the HTTP threads still answer --------------------------------
scene "$T/z.json" 0.5
code=$(post_json /v1/scenes "$T/z.json")
check scene_before_hold "status $code: $(head -c 200 "$T/body")" [ "$code" = 201 ]
code=$(parse_gate 0)
check gate_holds_parses "status $code: $(cat "$T/gate.json")" \
    bash -c "[ $code = 200 ] && grep -q '\"parses\":0' '$T/gate.json'"
parses0=$(metric rayd_scene_parses_total)
scene "$T/a.json" 1
scene "$T/b.json" 1.5
scene "$T/c.json" 2
printf '{"render":{"width":16,"height":12},"objects":[{"type":"sphere","radius":-1}]}' >"$T/bad.json"
post_bg a1 "$T/a.json"
post_bg a2 "$T/a.json"
post_bg a3 "$T/a.json"
post_bg b "$T/b.json"
queued_is() { curl -s -m 5 "$URL/v1/test/gate" | grep -q "\"parses_queued\":$1,"; }
# waiting_is N: N requests wait for the parses queued or running
waiting_is() { curl -s -m 5 "$URL/v1/test/gate" | grep -q "\"parses_waiting\":$1,"; }
wait_until 30 queued_is 2
check two_scenes_queued "gate $(curl -s -m 5 "$URL/v1/test/gate")" queued_is 2
for p in /healthz /readyz /metrics; do
    t=$(timed "$p")
    check "fast_while_parsing_${p#/}" "GET $p took ${t% *} s (status ${t#* }) with parses held" \
        bash -c "[ '${t#* }' = 200 ] && python3 -c 'import sys; sys.exit(float(sys.argv[1]) >= 1)' ${t% *}"
done
echo "# healthz while 2 parses are held: $(timed /healthz)"
check held_requests_wait "a1 answered '$(code_of a1)' while its parse is held" bash -c "! [ -s '$T/a1.code' ]"

# --- the queue's bound: one more distinct scene is refused -----------------------
code=$(post_json /v1/scenes "$T/c.json")
check queue_full_503 "status $code: $(head -c 300 "$T/body")" err_is "$T/body" 503 queue_full
check queue_full_message "$(head -c 300 "$T/body")" grep -q 'scene parse queue is full' "$T/body"
ra=$(header Retry-After)
check queue_full_retry_after "Retry-After '$ra'" bash -c "[[ '$ra' =~ ^[0-9]+$ ]] && [ '$ra' -ge 1 ]"
check queue_full_counted "rejections $(metric 'rayd_rejections_total{reason="parse_queue_full"}')" \
    [ "$(metric 'rayd_rejections_total{reason="parse_queue_full"}')" = 1 ]
# a cached scene is still answered at once, without a parse thread
code=$(post_json /v1/scenes "$T/z.json")
check cached_answers_while_held "status $code: $(head -c 200 "$T/body")" \
    bash -c "[ $code = 201 ] && grep -q '\"cached\":true' '$T/body'"

# --- identical bodies: one parse -------------------------------------------------
wait_until 30 waiting_is 4 # a1, a2, a3 and b, before the gate opens
code=$(parse_gate open)
for n in a1 a2 a3 b; do wait_until 120 done_code $n; done
ida=$(sha256sum "$T/a.json" | cut -d' ' -f1)
for n in a1 a2 a3; do
    check "coalesced_answer_$n" "status $(code_of $n): $(head -c 200 "$T/$n.body")" \
        bash -c "[ '$(code_of $n)' = 201 ] && grep -q '\"id\":\"$ida\"' '$T/$n.body'"
done
parses1=$(metric rayd_scene_parses_total)
check identical_posts_parsed_once "rayd_scene_parses_total $parses0 -> $parses1 (a three times, b once)" \
    [ "$parses1" = "$((parses0 + 2))" ]

# --- one error for all who sent the same bad body ------------------------------------
parse_gate 0 >/dev/null
post_bg e1 "$T/bad.json"
post_bg e2 "$T/bad.json"
# both requests waiting on the one parse queued: on a busy host the second
# curl may start after the first's parse would have ended
wait_until 30 waiting_is 2
check coalesced_error_joined "gate $(curl -s -m 5 "$URL/v1/test/gate")" queued_is 1
parse_gate open >/dev/null
wait_until 30 done_code e1
wait_until 30 done_code e2
check coalesced_error "e1 $(code_of e1) e2 $(code_of e2): $(head -c 200 "$T/e1.body")" \
    bash -c "[ '$(code_of e1)' = 422 ] && cmp -s '$T/e1.body' '$T/e2.body'"
check coalesced_error_pointer "$(head -c 300 "$T/e1.body")" err_is "$T/e1.body" 422 invalid_scene /objects/0/radius
check coalesced_error_parsed_once "parses $(metric rayd_scene_parses_total), was $parses1" \
    [ "$(metric rayd_scene_parses_total)" = "$((parses1 + 1))" ]

# --- a client gone while its scene waits: the parse still caches it ---------------
parse_gate 0 >/dev/null
scene "$T/d.json" 2.5
curl -s -m 1 -o /dev/null -H 'Content-Type: application/json' --data-binary @"$T/d.json" \
    "$URL/v1/render" 2>/dev/null
parse_gate open >/dev/null
queued_none() { curl -s -m 5 "$URL/v1/test/gate" | grep -q '"parses_queued":0,"parses_running":0'; }
wait_until 30 queued_none
code=$(post_json /v1/scenes "$T/d.json")
check gone_client_scene_cached "status $code: $(head -c 200 "$T/body")" \
    bash -c "[ $code = 201 ] && grep -q '\"cached\":true' '$T/body'"
code=$(timed /healthz)
check healthz_after_gone_client "healthz $code" [ "${code#* }" = 200 ]

# --- one stat per distinct file, per cached GET ------------------------------------
A=$T/assets
mkdir -p "$A"
printf 'v 0 0 -3\nv 1 0 -3\nv 0 1 -3\nf 1 2 3\n' >"$A/tri.obj"
touch -d '2001-01-01 00:00:01' "$A/tri.obj"
python3 - "$T/many.json" 3000 <<'PY'
import json, sys
objs = [{"type": "mesh", "source": {"file": "tri.obj"}} for _ in range(int(sys.argv[2]))]
json.dump({"render": {"width": 8, "height": 6}, "objects": objs}, open(sys.argv[1], "w"))
PY
stop_rayd TERM
start_rayd --asset-dir "$A"
code=$(post_json /v1/scenes "$T/many.json")
idm=$(sha256sum "$T/many.json" | cut -d' ' -f1)
check many_refs_compiled "status $code: $(head -c 200 "$T/body")" [ "$code" = 201 ]
c0=$(metric rayd_scene_file_checks_total)
code1=$(req GET "/v1/scenes/$idm/image.png?x=0&y=0&w=2&h=2")
c1=$(metric rayd_scene_file_checks_total)
code2=$(req GET "/v1/scenes/$idm/image.png?x=0&y=0&w=2&h=2")
c2=$(metric rayd_scene_file_checks_total)
check one_stat_per_cached_get "GETs $code1 $code2; file checks $c0 -> $c1 -> $c2 for 3000 references to one file" \
    bash -c "[ $code1 = 200 ] && [ $code2 = 200 ] && [ '$c1' = $((c0 + 1)) ] && [ '$c2' = $((c1 + 1)) ]"

# a scene of 20 distinct files is checked on a parse thread: the same answers
for i in $(seq 1 20); do cp "$A/tri.obj" "$A/t$i.obj"; touch -d '2001-01-01 00:00:01' "$A/t$i.obj"; done
python3 - "$T/twenty.json" <<'PY'
import json, sys
objs = [{"type": "mesh", "source": {"file": "t%d.obj" % i}} for i in range(1, 21)]
json.dump({"render": {"width": 8, "height": 6}, "objects": objs}, open(sys.argv[1], "w"))
PY
idt=$(sha256sum "$T/twenty.json" | cut -d' ' -f1)
code1=$(post_json /v1/scenes "$T/twenty.json")
code2=$(post_json /v1/scenes "$T/twenty.json")
check many_files_cached_post "statuses $code1 $code2: $(head -c 200 "$T/body")" \
    bash -c "[ $code1 = 201 ] && [ $code2 = 201 ] && grep -q '\"cached\":true' '$T/body'"
c0=$(metric rayd_scene_file_checks_total)
code=$(req GET "/v1/scenes/$idt/image.png")
check many_files_cached_get "GET $code, file checks $c0 -> $(metric rayd_scene_file_checks_total)" \
    bash -c "[ $code = 200 ] && [ '$(metric rayd_scene_file_checks_total)' = $((c0 + 20)) ]"
printf 'v 0 0 -3\nv 2 0 -3\nv 0 1 -3\nf 1 2 3\n' >"$A/t7.obj"
code=$(req GET "/v1/scenes/$idt/image.png")
check many_files_changed_unknown "GET after a change: $code $(head -c 200 "$T/body")" \
    err_is "$T/body" 404 scene_unknown

# --- a request's scene is parsed before the frames of a frame-range job -------------
# The job's scene and its check of the frames' values are let through (two parses);
# its first frames then wait in the queue (the
# gate), a new scene is posted behind them, and the one parse let start is the
# new scene's.  Before, the queue went in order: the new scene waited for the
# frames, each parsed in full (seconds for a scene of big textures).
stop_rayd TERM
start_rayd --test-gate open --parse-threads 2
cat >"$T/anim.json" <<'EOF2'
{"animation": {"start": 0, "end": 5}, "render": {"width": 16, "height": 12},
 "camera": {"keyframes": [{"frame": 0, "position": [0, 0, 4]}, {"frame": 5, "position": [1, 0, 4]}]},
 "objects": [{"type": "sphere", "center": [0, 0, -3]}]}
EOF2
parse_gate 2 >/dev/null
code=$(post_json "/v1/jobs?frames=0-5" "$T/anim.json")
check frames_job_made "status $code: $(head -c 200 "$T/body")" [ "$code" = 202 ]
wait_until 30 queued_is 2 # two frames, the gate closed after the job's own two parses
scene "$T/late.json" 2.75
post_bg late "$T/late.json"
wait_until 30 queued_is 3
parse_gate 1 >/dev/null
wait_until 30 done_code late
check request_before_frames "late scene $(code_of late); gate $(curl -s -m 5 "$URL/v1/test/gate")" \
    bash -c "[ '$(code_of late)' = 201 ] && curl -s -m 5 '$URL/v1/test/gate' | grep -q '\"parses_queued\":2,'"
parse_gate open >/dev/null

# --- a drain answers a held parse's request ----------------------------------------
stop_rayd TERM
start_rayd --test-gate open --drain-seconds 2
parse_gate 0 >/dev/null
post_bg dr "$T/c.json"
wait_until 30 queued_is 1
stop_rayd TERM
check drain_exits_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]
wait_until 30 done_code dr
check drain_answers_held_parse "status $(code_of dr): $(head -c 200 "$T/dr.body")" \
    err_is "$T/dr.body" 503 draining

# --- one client's scenes cannot hold the parse queue ------------------------------------
# Client a queues 6 scenes of a queue of 8 (their parses held); its 7th is refused, the
# last quarter being kept for clients with less queued, and client b's scene takes a
# place.  Then the parses go on one at a time: b's is the second parsed, not the seventh
# (the client with the fewest of the last parses started goes first).  Before, a's 20
# scenes of big textures made b's new scene wait 32 s, and with a full queue 503.
start_rayd --test-gate open --parse-threads 1 --parse-queue 8 --client-header X-Client
parse_gate 0 >/dev/null
for i in 1 2 3 4 5 6; do
    scene "$T/fa$i.json" "3.$i"
    post_bg fa$i "$T/fa$i.json" -H 'X-Client: a'
    wait_until 30 queued_is $i
done
scene "$T/fa7.json" 3.7
code=$(post_json /v1/scenes "$T/fa7.json" -H 'X-Client: a')
check parse_share_refuses_flood "status $code: $(head -c 300 "$T/body")" err_is "$T/body" 503 queue_full
scene "$T/fb.json" 4.1
post_bg fb "$T/fb.json" -H 'X-Client: b'
wait_until 30 queued_is 7
check parse_share_takes_other "gate $(curl -s -m 5 "$URL/v1/test/gate")" queued_is 7
parse_gate 2 >/dev/null
wait_until 60 done_code fb
answered_a=0
for i in 1 2 3 4 5 6; do [ -s "$T/fa$i.code" ] && answered_a=$((answered_a + 1)); done
check parse_turns_other_client "b: '$(code_of fb)', a answered $answered_a of 6" \
    eval '[ "$(code_of fb)" = 201 ] && [ "$answered_a" -le 1 ]'
parse_gate open >/dev/null
for i in 1 2 3 4 5 6; do wait_until 60 done_code fa$i; done
stop_rayd TERM

exit $((NFAIL > 0))
