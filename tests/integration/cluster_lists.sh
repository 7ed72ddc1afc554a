#!/usr/bin/env bash
# cluster_lists.sh -- rayd --redis: GET /v1/jobs reads the asking client's
# own jobs, however many other clients have.
#
# A real redis-server on a free loopback port (lib/redis.sh) and two nodes
# that tell clients apart by X-Client.  bob posts one job, then alice posts
# 5,100 tiny ones.  bob's list must name his job, and cost Redis a handful
# of commands.  Then a node that keeps ended jobs 1 s: carol's 600 jobs,
# never listed, must leave her list (and Redis but for their tombstones)
# once they expired.  Then --max-jobs 16 must bound the ended jobs kept too.
# Until the lists were kept per client (rayd:jobs:CLIENT),
# every job of the cluster was one ZSET: bob's list read up to 5,000 of
# alice's jobs, two round trips each, on the node's one request thread
# (0.4 s, some 10,000 Redis commands, every other job route of that node
# waiting behind it), then stopped there and answered an empty list with
# no next page: his job was lost to him.  Every process is stopped by its
# PID.
# rayd-test: long (5,100 jobs posted and rendered)
source "$(dirname "$0")/lib/common.sh"
source "$(dirname "$0")/lib/redis.sh"

python3 - "$RAYD_ROOT/scenes/spheres.json" "$T/tiny.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
d["render"].update(width=16, height=16, samples=1)
json.dump(d, open(sys.argv[2], "w"))
PY
# post NODE CLIENT N: N jobs of CLIENT on one connection; prints how many got 202
post() {
    python3 - "${NODE_URL[$1]#http://}" "$2" "$3" "$T/tiny.json" <<'PY'
import http.client, sys
host, port = sys.argv[1].split(":")
body = open(sys.argv[4], "rb").read()
c = http.client.HTTPConnection(host, int(port), timeout=30)
ok = 0
for _ in range(int(sys.argv[3])):
    c.request("POST", "/v1/jobs", body, {"Content-Type": "application/json", "X-Client": sys.argv[2]})
    r = c.getresponse()
    r.read()
    ok += r.status == 202
print(ok)
PY
}
commands() { rcli info stats | tr -d '\r' | awk -F: '$1 == "total_commands_processed" {print $2}'; }
unfinished() { [ "$(rcli scard rayd:unfinished)" = 0 ]; }

start_redis
for i in 1 2; do
    start_node $i --threads 2 --client-header X-Client --max-jobs 100000 --job-ttl 600 --redis "$REDIS_URL"
done

# --- bob's one job, then 5,100 of alice's ----------------------------------------------------
BOB=$(curl -s -m 30 -H 'Content-Type: application/json' -H 'X-Client: bob' \
    --data-binary @"$T/tiny.json" "${NODE_URL[1]}/v1/jobs" |
    python3 -c 'import json,sys; print(json.load(sys.stdin).get("id", ""))')
n=$(post 2 alice 5100)
check alice_posted "202s: $n of 5100" [ "$n" = 5100 ]
wait_until 300 unfinished
check all_ended "unfinished in Redis: $(rcli scard rayd:unfinished)" unfinished

# --- bob's list: his job, for a few Redis commands -------------------------------------------
before=$(commands)
curl -s -m 60 -o "$T/bob.json" -H 'X-Client: bob' "${NODE_URL[1]}/v1/jobs"
spent=$(($(commands) - before))
names_bob() { python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); sys.exit(0 if [j["id"] for j in d["jobs"]] == [sys.argv[2]] else 1)' "$T/bob.json" "$BOB"; }
check list_finds_own_job "bob's list: $(head -c 300 "$T/bob.json")" names_bob
# the puller's own commands (a blocked read every 100 ms, the figures) run meanwhile too
check list_reads_own_jobs_only "one list cost Redis $spent commands" [ "$spent" -lt 200 ]

# --- alice's list: hers, newest first, paged as ever -----------------------------------------
curl -s -m 60 -o "$T/alice.json" -H 'X-Client: alice' "${NODE_URL[2]}/v1/jobs?limit=100"
alice_page() {
    python3 - "$T/alice.json" "$BOB" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
ids = [j["id"] for j in d["jobs"]]
made = [j["created_at"] for j in d["jobs"]]
sys.exit(0 if len(ids) == 100 and sys.argv[2] not in ids and made == sorted(made, reverse=True)
         and d["next_url"] else 1)
PY
}
check list_pages_own_jobs "alice's first page: $(head -c 300 "$T/alice.json")" alice_page

# --- jobs that expired leave their client's list, listed or not ------------------------------
# a node keeping ended jobs 1 s; carol never lists.  Redis cannot expire a ZSET's member: until
# rayd:ended was swept, each of her 600 jobs stayed in her list (and in Redis) for good.
for i in 1 2; do kill -TERM "${NODE_PID[$i]}" && wait "${NODE_PID[$i]}" 2>/dev/null; done
rcli flushall >/dev/null
start_node 3 --threads 2 --client-header X-Client --max-jobs 100000 --job-ttl 1 --redis "$REDIS_URL"
n=$(post 3 carol 600)
check carol_posted "202s: $n of 600" [ "$n" = 600 ]
wait_until 120 unfinished
swept() { [ "$(listed_jobs)" = 0 ] && [ "$(rcli zcard rayd:ended)" = 0 ] && [ -z "$(rcli --scan --pattern 'rayd:ended:*')" ]; }
wait_until 30 swept
check expired_jobs_leave_lists "still listed: $(listed_jobs), rayd:ended: $(rcli zcard rayd:ended), keys: $(rcli --scan --pattern 'rayd:jobs*' | head -3 | tr '\n' ' ')" swept
job_keys() { rcli --scan --pattern 'rayd:{*}:*' | grep -vc ':gone$'; }
check expired_jobs_keep_only_tombstones "keys besides tombstones: $(job_keys)" [ "$(job_keys)" = 0 ]

# --- --max-jobs counts ended jobs too, as on one node -----------------------------------------
# dave's first job ends, then 20 more are posted one after another under --max-jobs 16 and a
# 600 s TTL: the ones that ended first are forgotten (410 job_evicted), so Redis keeps at most
# 16 jobs, not every job of the last ten minutes (41 MB for 1,079 kept before, and growing with
# the POST rate).  Once dave's jobs end before his next POST, the ones forgotten are his own:
# erin's job, ended before his flood, stays (it was forgotten when the cluster forgot anyone's
# oldest; while all of his are unfinished, anyone's still goes, as on one node).
kill -TERM "${NODE_PID[3]}" && wait "${NODE_PID[3]}" 2>/dev/null
rcli flushall >/dev/null
start_node 4 --threads 2 --client-header X-Client --max-jobs 16 --job-ttl 600 --redis "$REDIS_URL"
FIRST=$(curl -s -m 30 -H 'Content-Type: application/json' -H 'X-Client: dave' \
    --data-binary @"$T/tiny.json" "${NODE_URL[4]}/v1/jobs" |
    python3 -c 'import json,sys; print(json.load(sys.stdin).get("id", ""))')
wait_until 60 unfinished
# erin's one job ends before dave's flood: his POSTs forget his own ended jobs first, not hers
ERIN=$(curl -s -m 30 -H 'Content-Type: application/json' -H 'X-Client: erin' \
    --data-binary @"$T/tiny.json" "${NODE_URL[4]}/v1/jobs" |
    python3 -c 'import json,sys; print(json.load(sys.stdin).get("id", ""))')
wait_until 60 unfinished
n=0 # one at a time, each ended before the next, as a client that waits for its results
for _ in 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20; do
    n=$((n + $(post 4 dave 1)))
    wait_until 60 unfinished
done
records() { rcli --scan --pattern 'rayd:{*}:job' | wc -l; }
bounded() { [ "$n" -ge 17 ] && [ "$(records)" -le 16 ] && [ "$(listed_jobs)" -le 16 ]; }
check ended_jobs_bounded "job records kept: $(records) of --max-jobs 16; listed $(listed_jobs); $n of 20 posted" bounded
code=$(curl -s -m 30 -o "$T/first.json" -w '%{http_code}' -H 'X-Client: dave' "${NODE_URL[4]}/v1/jobs/$FIRST")
check first_job_evicted "$code $(head -c 300 "$T/first.json")" err_is "$T/first.json" 410 job_evicted
code=$(curl -s -m 30 -o "$T/erin.json" -w '%{http_code}' -H 'X-Client: erin' "${NODE_URL[4]}/v1/jobs/$ERIN")
check flood_keeps_others_job "erin's: $code $(head -c 300 "$T/erin.json")" \
    bash -c "[ $code = 200 ] && grep -q '\"state\":\"succeeded\"' '$T/erin.json'"
# each client's ended jobs in its own ZSET too, the same as rayd:ended
erins_ended() { rcli zrange "rayd:ended:$(rcli hget "rayd:{$ERIN}:job" client)" 0 -1; }
per_client() { for k in $(rcli --scan --pattern 'rayd:ended:*'); do rcli zcard "$k"; done | awk '{n += $1} END {print n + 0}'; }
check ended_per_client "rayd:ended $(rcli zcard rayd:ended), per client $(per_client), erin's: $(erins_ended)" \
    bash -c "[ $(rcli zcard rayd:ended) = $(per_client) ] && [ '$(erins_ended)' = '$ERIN' ]"
# an id left in a client's set alone (swept by a node of a version before the sets) is dropped,
# not counted as a job forgotten: the ended jobs stay within --max-jobs
dcl=$(rcli hget "rayd:{$(rcli zrange rayd:ended -1 -1 | cut -d' ' -f1)}:job" client)
rcli zadd "rayd:ended:$dcl" 1 ffffffffffffffffffffffffffffffff >/dev/null
post 4 dave 1 >/dev/null # (the newest ended job, whose client dcl is, was dave's)
wait_until 60 unfinished
stale_gone() { [ -z "$(rcli zscore "rayd:ended:$dcl" ffffffffffffffffffffffffffffffff)" ] &&
    [ "$(rcli zcard rayd:ended)" -le 16 ]; }
check stale_client_entry_dropped "rayd:ended $(rcli zcard rayd:ended) of --max-jobs 16; stale: $(rcli zscore "rayd:ended:$dcl" ffffffffffffffffffffffffffffffff)" stale_gone
[ "$NFAIL" = 0 ]
