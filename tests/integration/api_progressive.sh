#!/usr/bin/env bash
# api_progressive.sh -- progressive jobs (POST /v1/jobs?progressive=1): one
# "pass" event per finished pass, each pass's image byte for byte the plain
# render of its sample count (POST /v1/render of the scene with those
# samples), the latest pass answered while the job runs (X-Rayd-Pass), a
# client stop keeping what is done, the time and noise budgets, and bad
# options answered 400 naming the parameter.
source "$(dirname "$0")/lib/common.sh"

# Work in flight is held by the test gate, never by a render sized to be slow.
start_rayd --threads 2 --test-gate open
scene "$T/p8.json" 128 64 8 cornell # two 64x64 tiles a pass
for n in 1 2 3 4 6 8; do
    scene "$T/p$n.json" 128 64 $n cornell
    code=$(post_json /v1/render "$T/p$n.json")
    cp "$T/body" "$T/ref$n.png"
    check "ref_${n}_rendered" "status $code" [ "$code" = 200 ]
done

# sse_passes FILE: "samples:url ..." of the pass events, then the done event's data
sse_passes() {
    PYTHONPATH="$SSE_LIB" python3 - "$1" <<'PY'
import json, sys
import sse
ev = sse.events(sys.argv[1])
passes = [json.loads(e["data"]) for e in ev if e.get("event") == "pass"]
done = [json.loads(e["data"]) for e in ev if e.get("event") == "done"]
print(" ".join("%d:%s" % (p["samples"], p["image_url"]) for p in passes))
print(json.dumps(done[0] if done else None))
PY
}

# --- doubling passes: 1, 2, 4, 8, each equal to its plain render ------------------
code=$(post_json "/v1/jobs?progressive=1" "$T/p8.json")
id=$(jfield "$T/body" id)
check prog_post_202 "status $code $(head -c 200 "$T/body")" [ "$code" = 202 ]
curl -s -N -m 60 "$URL/v1/jobs/$id/events" >"$T/sse.txt"
sse_passes "$T/sse.txt" >"$T/passes.txt"
got=$(head -n 1 "$T/passes.txt" | sed 's#:[^ ]*##g')
check prog_pass_events "samples '$got': $(head -c 400 "$T/sse.txt")" [ "$got" = "1 2 4 8" ]
check prog_done_event "$(tail -n 1 "$T/passes.txt")" \
    bash -c "grep -q '\"state\": \"succeeded\"' '$T/passes.txt' && grep -q '\"samples\": 8' '$T/passes.txt'"
for pu in $(head -n 1 "$T/passes.txt"); do
    n=${pu%%:*} u=${pu#*:}
    code=$(req GET "$u")
    check "prog_pass_${n}_equals_plain" "status $code, X-Rayd-Samples $(header X-Rayd-Samples)" \
        bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Samples)' = $n ] && cmp -s '$T/body' '$T/ref$n.png'"
done
code=$(req GET "/v1/jobs/$id/image.png")
check prog_final_image "status $code, pass $(header X-Rayd-Pass)" \
    bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Pass)' = 4/4 ] && cmp -s '$T/body' '$T/ref8.png'"
req GET "/v1/jobs/$id" >/dev/null
check prog_status_passes "$(cat "$T/body")" python3 -c '
import json, sys
j = json.load(open(sys.argv[1])); p = j["passes"]
ok = j["state"] == "succeeded" and j["progress"] == 1 and p["done"] == 4 and p["total"] == 4
ok = ok and p["samples"] == 8 and p["samples_target"] == 8 and p["stopped_by"] is None
ok = ok and p["noise"] > 0 and p["image_url"].endswith("?pass=4")
sys.exit(0 if ok else 1)' "$T/body"

# --- every k samples: 3, 6, 8 ----------------------------------------------------------
code=$(post_json "/v1/jobs?progressive=1&pass_step=3" "$T/p8.json")
id=$(jfield "$T/body" id)
curl -s -N -m 60 "$URL/v1/jobs/$id/events" >"$T/sse3.txt"
sse_passes "$T/sse3.txt" >"$T/passes3.txt"
got=$(head -n 1 "$T/passes3.txt" | sed 's#:[^ ]*##g')
check prog_step_events "samples '$got'" [ "$got" = "3 6 8" ]
for n in 3 6; do
    k=$((n / 3))
    code=$(req GET "/v1/jobs/$id/image.png?pass=$k")
    check "prog_step_pass_${n}_equals_plain" "status $code" \
        bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/ref$n.png'"
done
# a pass past the last names the job's own count; one given twice is refused
code=$(req GET "/v1/jobs/$id/image.png?pass=99")
check pass_past_last_names_count "status $code $(head -c 200 "$T/body")" \
    bash -c "[ $code = 400 ] && grep -q 'pass number of this job, 1..3' '$T/body'"
# a pass number is decimal digits only, as every number of the query
for p in 0x1 %2B1 %201 1.0; do
    code=$(req GET "/v1/jobs/$id/image.png?pass=$p")
    check "pass_not_decimal_$p" "status $code $(head -c 200 "$T/body")" \
        bash -c "[ $code = 400 ] && grep -q '\"parameter\":\"pass\"' '$T/body'"
done
code=$(req GET "/v1/jobs/$id/image.png?pass=1&pass=2")
check pass_twice_400 "status $code $(head -c 200 "$T/body")" \
    bash -c "[ $code = 400 ] && grep -q 'pass: given more than once' '$T/body'"


# --- held by the gate: the latest pass while running, then a client stop ---------------
gate 0
code=$(post_json "/v1/jobs?progressive=1" "$T/p8.json")
id=$(jfield "$T/body" id)
code=$(req GET "/v1/jobs/$id/image.png")
check prog_image_202_before_a_pass "status $code" [ "$code" = 202 ]
gate 2 # the first pass's two tiles
wait_until 60 job_is "$id" done 1
wait_until 30 gate_is held 2 # the second pass waits at the gate
code=$(req GET "/v1/jobs/$id/image.png")
check prog_latest_pass_while_running \
    "status $code, X-Rayd-Pass $(header X-Rayd-Pass), Cache-Control $(header Cache-Control)" \
    bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Pass)' = 1/4 ] && [ '$(header X-Rayd-Samples)' = 1 ] && cmp -s '$T/body' '$T/ref1.png'"
check prog_running "state $(jfield "$T/body" state)" job_state_is "$id" running
code=$(req POST "/v1/jobs/$id/stop")
check prog_stop_200 "status $code $(head -c 300 "$T/body")" bash -c \
    "[ $code = 200 ] && [ '$(jfield "$T/body" state)' = succeeded ] && [ '$(jfield "$T/body" stopped_by)' = client ]"
code=$(req GET "/v1/jobs/$id/image.png")
check prog_stop_keeps_pass "status $code, pass $(header X-Rayd-Pass)" \
    bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Pass)' = 1/4 ] && cmp -s '$T/body' '$T/ref1.png'"

# --- time budget: passed while pass 2 waits, it stops after its next tile ----------------
code=$(post_json "/v1/jobs?progressive=1&time_budget=0.05" "$T/p8.json")
id=$(jfield "$T/body" id)
gate 2
wait_until 60 job_is "$id" done 1
sleep 0.1 # the budget is past: time only moves forward
gate 1
wait_until 60 job_state_is "$id" succeeded
check prog_time_budget "$(head -c 400 "$T/body")" bash -c \
    "[ '$(jfield "$T/body" stopped_by)' = time_budget ] && [ '$(jfield "$T/body" samples)' = 1 ]"
gate open

# --- noise budget: any estimate is below 1, so it stops at the first one (pass 2) ---------
code=$(post_json "/v1/jobs?progressive=1&noise_target=1" "$T/p8.json")
id=$(jfield "$T/body" id)
wait_until 60 job_state_is "$id" succeeded
check prog_noise_budget "$(head -c 400 "$T/body")" bash -c \
    "[ '$(jfield "$T/body" stopped_by)' = noise_target ] && [ '$(jfield "$T/body" samples)' = 2 ]"
code=$(req GET "/v1/jobs/$id/image.png")
check prog_noise_image "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/ref2.png'"

# --- cancelled half-way through pass 2: the done event's progress is the job's ----------
gate 0
gate_read
s0=$(jfield "$T/gate.json" started) # "started" counts every tile since rayd began
code=$(post_json "/v1/jobs?progressive=1" "$T/p8.json")
id=$(jfield "$T/body" id)
gate 3 # pass 1's two tiles and one of pass 2's
wait_until 60 job_is "$id" done 1
wait_until 30 gate_is started $((s0 + 3))
check prog_cancel_in_pass_2 "gate $(cat "$T/gate.json"), $s0 started before" gate_is started $((s0 + 3))
code=$(req DELETE "/v1/jobs/$id")
wait_until 30 job_state_is "$id" canceled
gate open
curl -s -N -m 60 "$URL/v1/jobs/$id/events" >"$T/sse-cancel.txt"
req GET "/v1/jobs/$id" >/dev/null
check prog_cancel_done_progress "$(tail -n 3 "$T/sse-cancel.txt") vs $(head -c 300 "$T/body")" \
    env PYTHONPATH="$SSE_LIB" python3 -c '
import json, sys
import sse
done = [json.loads(e["data"]) for e in sse.events(sys.argv[1]) if e.get("event") == "done"]
job = json.load(open(sys.argv[2]))
ok = len(done) == 1 and done[0]["state"] == "canceled" and 0 < job["progress"] < 1
sys.exit(0 if ok and abs(done[0]["progress"] - job["progress"]) < 1e-4 else 1)' "$T/sse-cancel.txt" "$T/body"

# --- a plain job cannot be stopped-and-kept; bad options name their parameter -------------
code=$(post_json /v1/jobs "$T/p1.json")
id=$(jfield "$T/body" id)
code=$(req POST "/v1/jobs/$id/stop")
check plain_job_stop_409 "status $code" err_is "$T/body" 409 not_progressive
# bad_option STATUS PARAMETER: a 400 naming PARAMETER
bad_option() { [ "$1" = 400 ] && [ "$(json "$T/body" 'j["error"]["parameter"]')" = "$2" ]; }
for q in "progressive=2:progressive" "pass_step=2:pass_step" "progressive=1&pass_step=0.5:pass_step" \
    "progressive=1&pass_step=-1:pass_step" "progressive=1&noise_target=2:noise_target" \
    "progressive=1&time_budget=abc:time_budget" "progressive=1&colour=red:colour" \
    "progressive=1&noise_target=0.5&noise_target=abc:noise_target" \
    "progressive=1&pass_step=2&pass_step=3:pass_step" "progressive=1&progressive=1:progressive" \
    "progressive=1&time_budget=0x10:time_budget" "progressive=1&time_budget=inf:time_budget" \
    "progressive=1&time_budget=1e1:time_budget" "progressive=1&time_budget=%2B5:time_budget" \
    "progressive=1&time_budget=%205:time_budget" "progressive=1&noise_target=nan:noise_target" \
    "progressive=1&pass_step=0x2:pass_step" "progressive=1&pass_step=1048577:pass_step" \
    "progressive=1&time_budget=86401:time_budget"; do
    code=$(post_json "/v1/jobs?${q%%:*}" "$T/p8.json")
    check "bad_option_${q%%:*}" "status $code $(head -c 200 "$T/body")" bad_option "$code" "${q##*:}"
    case $q in *"${q##*:}="*"${q##*:}="*)
        check "bad_option_twice_${q##*:}" "$(head -c 200 "$T/body")" grep -q 'given more than once' "$T/body" ;;
    esac
done
# a most said as a plain number (not 1e+06); pass_step's most is rayd-render's --pass-step's
check most_said_plainly "$(head -c 200 "$T/body")" grep -q 'at most 86400"' "$T/body"
code=$(post_json "/v1/jobs?progressive=1&pass_step=1048576" "$T/p8.json")
check pass_step_most_taken "status $code $(head -c 200 "$T/body")" [ "$code" = 202 ]
scene "$T/p100.json" 64 64 100 cornell
code=$(post_json "/v1/jobs?progressive=1&pass_step=1" "$T/p100.json")
check too_many_passes "status $code $(head -c 200 "$T/body")" \
    bash -c "[ $code = 400 ] && grep -q 'more than 64 passes' '$T/body'"
code=$(req GET "/v1/jobs/$id/image.png?pass=1")
check pass_of_plain_job_400 "status $code" [ "$code" = 400 ]

stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]
