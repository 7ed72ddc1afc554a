#!/usr/bin/env bash
# jobs_ttl.sh -- --job-ttl counts from a job's end, not its POST, and a
# forgotten job answers 410 Gone with why, never the 404 of a wrong id.
#
# A render is held at the test gate until it is older than the TTL (20 s),
# then let go: it must still be there when it ends, with its image, for
# about the TTL after that; then every route of it answers 410 job_expired
# naming how and when it ended; an id this server never gave stays 404
# job_unknown.  (On 3f5321f the job was forgotten within one watcher tick
# of its end, and a poller saw 202 then 404.)  The TTL's seconds pass by
# the test gate's clock (?clock=S: rayd's clock jumps S seconds ahead), not
# by waiting them out.
source "$(dirname "$0")/lib/common.sh"

# TTL 20 s: what is checked right after the end has those seconds, even on a
# machine so busy that two requests are seconds apart
TTL=20
start_rayd --threads 1 --job-ttl $TTL --test-gate 0
# skip S: rayd's clock S seconds ahead, as if they had passed
skip() { curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?clock=$1" >/dev/null; }
# a jump back, a word or more than a day is refused, and moves nothing
for bad in -1 x 86401 1.5; do
    code=$(req POST "/v1/test/gate?clock=$bad")
    check "ttl_clock_bad_$bad" "status $code: $(head -c 200 "$T/body")" err_is "$T/body" 400 bad_parameter
done
gate_read
check ttl_clock_bad_moves_nothing "gate: $(head -c 300 "$T/gate.json")" [ "$(jfield "$T/gate.json" clock_skipped_s)" = 0 ]
scene "$T/s.json" 32 32 1 spheres 3

code=$(post_json /v1/jobs "$T/s.json")
id=$(jfield "$T/body" id)
check ttl_job_posted "status $code: $(head -c 200 "$T/body")" [ "$code" = 202 ]

# held at the gate until it is well past its TTL (age_s counts from the POST)
age_over() {
    req GET "/v1/jobs/$id" >/dev/null &&
        python3 -c 'import json,sys; sys.exit(0 if json.load(open(sys.argv[1]))["age_s"] > float(sys.argv[2]) else 1)' \
            "$T/body" "$1"
}
# a cancelled job ends at its DELETE: kept for the TTL after that, then 410
# with state canceled, while the held one (older, but not ended) stays
scene "$T/c.json" 32 32 1 spheres 4
post_json /v1/jobs "$T/c.json" >/dev/null
idc=$(jfield "$T/body" id)
code=$(req DELETE "/v1/jobs/$idc")
check ttl_cancel_200 "status $code" [ "$code" = 200 ]
code=$(req GET "/v1/jobs/$idc")
check ttl_cancelled_kept "status $code right after the DELETE: $(head -c 300 "$T/body")" \
    bash -c "[ $code = 200 ] && [ '$(jfield "$T/body" state)' = canceled ]"
status_of_is() { [ "$(req GET "/v1/jobs/$1")" = "$2" ]; }
skip $((TTL + 2))
check ttl_clock_skipped "gate: $(head -c 300 "$T/gate.json")" [ "$(jfield "$T/gate.json" clock_skipped_s)" = $((TTL + 2)) ]
wait_until 60 status_of_is "$idc" 410
check ttl_cancelled_expired "status $(req GET "/v1/jobs/$idc"): $(head -c 300 "$T/body")" bash -c \
    "[ '$(json "$T/body" 'j["error"]["code"]')' = job_expired ] && [ '$(json "$T/body" 'j["error"]["state"]')' = canceled ]"

wait_until 60 age_over $((TTL + 2))
check ttl_held_job_kept "status $(req GET "/v1/jobs/$id"): $(head -c 200 "$T/body")" \
    job_state_is "$id" queued

# let it end: it is there when it ends, with its image, for the TTL after
# (one answer shows both: succeeded, and expires_in_s of the TTL left)
gate open
wait_until 60 job_state_is "$id" succeeded
check ttl_long_job_succeeded "last answer: $(head -c 300 "$T/body")" \
    bash -c "[ '$(jfield "$T/body" state)' = succeeded ]"
left=$(jfield "$T/body" expires_in_s)
in_ttl() { python3 -c 'import sys
try: sys.exit(0 if 0 <= float(sys.argv[1]) <= float(sys.argv[2]) else 1)
except ValueError: sys.exit(1)' "$1" "$TTL"; }
check ttl_expires_in "expires_in_s '$left'" in_ttl "$left"
code=$(req GET "/v1/jobs/$id/image.png")
check ttl_long_job_image "status $code: $(head -c 200 "$T/body" | tr -c '[:print:]' .)" \
    bash -c "[ $code = 200 ] && [ '$(png_size "$T/body" 2>/dev/null)' = 32x32 ]"

# then it goes: 410 job_expired with how and when it ended, on every route
skip $((TTL + 1))
wait_until 60 status_of_is "$id" 410
code=$(req GET "/v1/jobs/$id")
check ttl_expired_410 "status $code: $(head -c 300 "$T/body")" err_is "$T/body" 410 job_expired
check ttl_expired_says_when "$(head -c 400 "$T/body")" python3 - "$T/body" $TTL <<'PY'
import json, sys, datetime
e = json.load(open(sys.argv[1]))["error"]
p = lambda s: datetime.datetime.strptime(s, "%Y-%m-%dT%H:%M:%SZ")
try:
    kept = (p(e["forgotten_at"]) - p(e["ended_at"])).total_seconds()
    ok = e["state"] == "succeeded" and kept >= int(sys.argv[2]) and "--job-ttl" in e["message"] \
        and e["ended_at"] in e["message"]
except (KeyError, ValueError):
    ok = False
sys.exit(0 if ok else 1)
PY
check ttl_expired_no_store "Cache-Control '$(header Cache-Control)'" [ "$(header Cache-Control)" = no-store ]
for route in image.png image.exr events; do
    code=$(req GET "/v1/jobs/$id/$route")
    check "ttl_expired_${route}_410" "status $code: $(head -c 200 "$T/body")" \
        err_is "$T/body" 410 job_expired
done
code=$(req DELETE "/v1/jobs/$id")
check ttl_expired_delete_410 "status $code: $(head -c 200 "$T/body")" err_is "$T/body" 410 job_expired

# an id this server never gave is still a 404
code=$(req GET "/v1/jobs/0123456789abcdef0123456789abcdef")
check ttl_unknown_still_404 "status $code: $(head -c 200 "$T/body")" err_is "$T/body" 404 job_unknown

stop_rayd TERM
check ttl_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]

