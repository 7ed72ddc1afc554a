#!/usr/bin/env bash
# deadline.sh -- --max-render-seconds: a render still running that long after
# its first tile is stopped.  A job fails with a message naming the limit, a
# synchronous render answers 413 with it, a progressive job ends with its
# latest pass; rayd_canceled_total{reason="deadline"} counts them.
#
# No outcome depends on how fast the machine renders.  Every render here
# outlasts the limit by construction: the test gate lets its first tiles
# start and never the rest, so it is still running when the limit passes,
# however fast the machine.  What must end within the limit -- a job's first
# tile, a progressive job's first pass -- is at most two tiles of 8x64
# pixels at one sample (a fraction of a millisecond here: thousands of times
# under the 1 s).  And the plain render is priced at a few thousand rays, so
# far under 4x the limit at any rate this node could measure that it is not
# refused at the door (413 over_budget) instead of stopped by the deadline
# (413 too_large): the check tells the two apart.
source "$(dirname "$0")/lib/common.sh"

start_rayd --threads 1 --test-gate 0 --max-render-seconds 1
scene "$T/deadline.json" 8 128 1 spheres # two tiles of 8x64
scene "$T/p8.json" 8 128 8 cornell       # two tiles a pass

# --- an asynchronous job -----------------------------------------------------------
code=$(post_json /v1/jobs "$T/deadline.json")
id=$(jfield "$T/body" id)
gate 1
wait_until 60 job_state_is "$id" failed
check deadline_job_fails "state $(jfield "$T/body" state): $(head -c 300 "$T/body")" \
    bash -c "grep -q '\"state\":\"failed\"' '$T/body' && grep -q 'max-render-seconds' '$T/body'"
check deadline_job_one_tile "$(jfield "$T/body" tiles_done) tiles done" job_is "$id" tiles_done 1
req GET "/v1/jobs/$id" >/dev/null
ecode=$(json "$T/body" 'j["error"]["code"]')
check deadline_error_no_path "$(head -c 400 "$T/body")" \
    bash -c "[ '$ecode' = too_large ] && ! grep -q '\"path\"' '$T/body'"
check deadline_counted "$(metric 'rayd_canceled_total{reason="deadline"}')" \
    metric_is 'rayd_canceled_total{reason="deadline"}' 1

# --- a synchronous render: 413 naming the limit --------------------------------------
gate 1
code=$(post_json /v1/render "$T/deadline.json")
check deadline_render_413 "status $code: $(head -c 300 "$T/body")" \
    bash -c "[ $code = 413 ] && grep -q 'ran past the server.s limit of 1 s (--max-render-seconds)' '$T/body'"
check deadline_render_code "$(head -c 300 "$T/body")" err_is "$T/body" 413 too_large

# --- a progressive job keeps its latest pass -------------------------------------------
code=$(post_json "/v1/jobs?progressive=1" "$T/p8.json")
id=$(jfield "$T/body" id)
gate 2 # the first pass's two tiles
wait_until 60 job_state_is "$id" succeeded
check deadline_progressive_keeps_pass "$(head -c 400 "$T/body")" bash -c \
    "[ '$(jfield "$T/body" stopped_by)' = time_budget ] && [ '$(jfield "$T/body" samples)' = 1 ]"
gate open

stop_rayd; [ -n "${DEADLINE_ERR:-}" ] && cp "$T/rayd.err" "$DEADLINE_ERR"
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]
