#!/usr/bin/env bash
# jobs_list.sh -- GET /v1/jobs (a client's own jobs, newest first, paged,
# by state) and POST /v1/jobs?priority=low|normal|high.
#
# Clients are told apart by --client-header (X-Client), as a balancer
# would.  The test gate (--test-gate 0, one worker) holds every job, so the
# order in which their tiles start is the scheduler's choice alone: within
# one client the highest priority first, and a client's high priority never
# goes before another client whose turn it is.  On f1aafc1 GET /v1/jobs was
# 405 and ?priority= an unknown parameter (400).
source "$(dirname "$0")/lib/common.sh"

start_rayd --threads 1 --test-gate 0 --client-header X-Client
as() { # as CLIENT METHOD PATH [ARGS...]: req with X-Client: CLIENT
    local c=$1
    shift
    req "$@" -H "X-Client: $c"
}
post_as() { # post_as CLIENT NAME [QUERY]: the job's id into $T/NAME.id
    local code
    code=$(post_json "/v1/jobs${3:-}" "$T/$2.json" -H "X-Client: $1")
    jfield "$T/body" id >"$T/$2.id"
    [ "$code" = 202 ]
}
jid() { cat "$T/$1.id"; }
bad_param_is() { # bad_param_is FILE NAME: 400 bad_parameter naming the query parameter NAME
    err_is "$1" 400 bad_parameter && [ "$(json "$1" 'j["error"]["parameter"]')" = "$2" ]
}
for i in 1 2 3 4 5 6 7 8 9; do scene "$T/j$i.json" 32 32 1 spheres "$i"; done

# ---- listing -------------------------------------------------------------------------
for i in 1 2 3 4 5; do post_as alice "j$i"; done
post_as bob j6
code=$(as alice GET "/v1/jobs")
check list_200 "status $code: $(head -c 200 "$T/body")" [ "$code" = 200 ]
ids_are() { # ids_are FILE ID...: the page lists exactly these ids, in this order
    python3 - "$@" <<'PY'
import json, sys
ids = [j["id"] for j in json.load(open(sys.argv[1]))["jobs"]]
sys.exit(0 if ids == sys.argv[2:] else 1)
PY
}
check list_own_newest_first "$(head -c 300 "$T/body")" \
    ids_are "$T/body" "$(jid j5)" "$(jid j4)" "$(jid j3)" "$(jid j2)" "$(jid j1)"
as bob GET /v1/jobs >/dev/null
check list_other_client "$(head -c 300 "$T/body")" ids_are "$T/body" "$(jid j6)"
as carol GET /v1/jobs >/dev/null
check list_empty "$(head -c 300 "$T/body")" ids_are "$T/body"
as alice GET "/v1/jobs?limit=1" >/dev/null
check list_entry_fields "$(head -c 400 "$T/body")" python3 - "$T/body" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))["jobs"][0]
sys.exit(0 if j["state"] == "queued" and j["priority"] == "normal"
         and j["created_at"].endswith("Z") and j["tiles_total"] == 1 else 1)
PY

# paging: limit 2, following next_url to the end, sees each job once
pages() {
    local path="/v1/jobs?limit=2" got=() n=0
    while [ -n "$path" ] && [ $n -lt 10 ]; do
        as alice GET "$path" >/dev/null || return 1
        got+=($(json "$T/body" '" ".join(x["id"] for x in j["jobs"])'))
        path=$(json "$T/body" 'j["next_url"] or ""')
        n=$((n + 1))
    done
    [ "${got[*]}" = "$(jid j5) $(jid j4) $(jid j3) $(jid j2) $(jid j1)" ] && [ $n = 3 ]
}
check list_pages "pages did not give the 5 jobs once, newest first" pages
as alice GET "/v1/jobs?limit=3" >/dev/null
cursor=$(json "$T/body" 'j["next_after"]')
as alice GET "/v1/jobs?after=$cursor" >/dev/null
check list_after_cursor "$(head -c 300 "$T/body")" ids_are "$T/body" "$(jid j2)" "$(jid j1)"

# the state filter: cancel one, let one finish
as alice DELETE "/v1/jobs/$(jid j2)" >/dev/null
as alice GET "/v1/jobs?state=canceled" >/dev/null
check list_state_canceled "$(head -c 300 "$T/body")" ids_are "$T/body" "$(jid j2)"
as alice GET "/v1/jobs?state=queued" >/dev/null
check list_state_queued "$(head -c 300 "$T/body")" \
    ids_are "$T/body" "$(jid j5)" "$(jid j4)" "$(jid j3)" "$(jid j1)"

# bad values: 400 naming the parameter
for q in "limit=0" "limit=101" "limit=x" "after=-1" "after=1.5" "state=done" "state=queued&state=failed" "page=2"; do
    code=$(as alice GET "/v1/jobs?$q")
    p=${q%%=*}
    check "list_bad_$(echo "$q" | tr -c '[:alnum:]\n' _)" "status $code: $(head -c 200 "$T/body")" \
        bad_param_is "$T/body" "$p"
done

# ---- priority ------------------------------------------------------------------------
for q in "priority=urgent" "priority=HIGH" "priority=" "priority=low&priority=high"; do
    code=$(post_json "/v1/jobs?$q" "$T/j7.json" -H "X-Client: alice")
    check "priority_bad_$(echo "$q" | tr -c '[:alnum:]\n' _)" "status $code: $(head -c 200 "$T/body")" \
        bad_param_is "$T/body" priority
done
# a good value is taken (on f1aafc1 any ?priority= was an unknown parameter)
code=$(post_json "/v1/jobs?priority=low" "$T/j7.json" -H "X-Client: alice")
check priority_low_taken "status $code: $(head -c 200 "$T/body")" [ "$code" = 202 ]
code=$(post_json "/v1/jobs?priority=urgent" "$T/j8.json" -H "X-Client: alice")
check priority_bad_says_values "$(head -c 200 "$T/body")" grep -q "must be low, normal or high" "$T/body"

# a fresh rayd: dave posts low, normal, high; the high one starts first, then normal
kill -KILL "$RAYD_PID"; wait "$RAYD_PID" 2>/dev/null
start_rayd --threads 1 --test-gate 0 --client-header X-Client
post_as dave j1 "?priority=low" && post_as dave j2 && post_as dave j3 "?priority=high"
as dave GET "/v1/jobs/$(jid j3)" >/dev/null
check priority_in_json "$(head -c 300 "$T/body")" [ "$(jfield "$T/body" priority)" = high ]
gate 1
wait_until 60 job_state_is "$(jid j3)" succeeded
check priority_high_first "$(head -c 200 "$T/body")" job_state_is "$(jid j3)" succeeded
check priority_others_wait "low $(jfield "$T/body" state)" bash -c \
    "$(declare -f req job_is job_state_is jfield); T='$T' URL='$URL' AUTH=(); job_state_is $(jid j1) queued && job_state_is $(jid j2) queued"
gate 1
wait_until 60 job_state_is "$(jid j2)" succeeded
check priority_normal_second "$(head -c 200 "$T/body")" job_state_is "$(jid j1)" queued

# across clients the fair share decides: erin's low job was queued before
# frank's high one, neither was served yet: erin's turn comes first
post_as erin j4 "?priority=low"
post_as frank j5 "?priority=high"
gate 1
wait_until 60 job_state_is "$(jid j4)" succeeded
check priority_not_across_clients "$(head -c 200 "$T/body")" job_state_is "$(jid j5)" queued
gate open
wait_until 60 job_state_is "$(jid j5)" succeeded
check priority_all_done "$(head -c 200 "$T/body")" job_state_is "$(jid j1)" succeeded

exit $((NFAIL > 0))
