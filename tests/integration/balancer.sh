#!/usr/bin/env bash
# balancer.sh -- docker/nginx.conf with busy nodes, jobs and a token.
#
# Three `rayd --threads 1 --queue 1 --test-gate 0 --token-file` on loopback
# behind Debian's nginx running docker/nginx.conf itself (lib/nginx.sh).
# With the gates shut each node holds one render (waiting at its gate, its
# queue of one full) and refuses the next with 503 queue_full, so the
# cluster being full is a state the test builds, not a race.  Checks:
# - 10 concurrent renders through nginx: 3 accepted (200 once the gates
#   open), 7 answered rayd's own 503 JSON with Retry-After; never a 502 or
#   an HTML page;
# - the nodes that answered 503 are not ejected: renders right after go to
#   every node;
# - jobs: created through nginx on any node; a 404 job_unknown goes to the
#   client from the first node asked, not retried on the others (with
#   --redis every node answers for every job, so docker/nginx.conf no
#   longer looks for a job's node; tests/integration/k8s_manifests.sh checks
#   the file says so);
# - the tile cache: a tile fetched with the token is cached and served
#   again, a request without the token or with another gets 401 (never the
#   cached tile), and no file of the cache holds the token;
# - every node down: nginx answers a JSON 502 with Retry-After, not HTML.
# Every process is stopped by its PID; everything stays on loopback.
# rayd-test: long
source "$(dirname "$0")/lib/common.sh"
source "$RAYD_ROOT/tests/integration/lib/nginx.sh"

NGINX=$(command -v nginx || echo /usr/sbin/nginx)
[ -x "$NGINX" ] || { echo "FAIL setup: nginx missing (make deps installs it)"; exit 1; }

TOKEN="bal-$RANDOM$RANDOM$RANDOM-secret"
printf '%s\n' "$TOKEN" >"$T/token"
AUTH=(-H "Authorization: Bearer $TOKEN")

for i in 1 2 3; do
    start_node $i --threads 1 --queue 1 --test-gate 0 --token-file "$T/token"
done

# node_gate I TILES / node_gate_is I KEY VALUE: the test gate of node I
node_gate() { curl -s -m 30 -X POST -o /dev/null "${AUTH[@]}" "${NODE_URL[$1]}/v1/test/gate?tiles=$2"; }
node_gate_is() {
    curl -s -m 30 -o "$T/g$1.json" "${AUTH[@]}" "${NODE_URL[$1]}/v1/test/gate" &&
        [ "$(jfield "$T/g$1.json" "$2")" = "$3" ]
}
# node_count I "METHOD ROUTE" CODE: rayd_http_requests_total of node I (0 if absent)
node_count() {
    local v method=${2%% *} route=${2#* }
    v=$(curl -s -m 60 "${AUTH[@]}" "${NODE_URL[$1]}/metrics" |
        awk -v k="rayd_http_requests_total{route=\"$route\",method=\"$method\",code=\"$3\"} " 'index($0, k) == 1 {print $NF}')
    echo "${v:-0}"
}

NG=$T/nginx
nginx_start "$NG" "${NODE_URL[1]#http://}" "${NODE_URL[2]#http://}" "${NODE_URL[3]#http://}"
URL=http://127.0.0.1:$NGINX_PORT     # req, post_json: through nginx
wait_until 60 bash -c "[ \"\$(curl -s -o /dev/null -w '%{http_code}' '$URL/healthz')\" = 200 ]"
check nginx_up "nginx does not answer /healthz on $URL" \
    [ "$(curl -s -o /dev/null -w '%{http_code}' "$URL/healthz")" = 200 ]

# --- 10 concurrent renders on 3 nodes that hold 1 each ----------------------------
for k in $(seq 1 10); do scene "$T/s$k.json" 48 32 1 spheres "$k"; done
for k in $(seq 1 10); do
    curl -s -m 120 -o "$T/r$k.body" -D "$T/r$k.head" -w '%{http_code}' "${AUTH[@]}" \
        -H 'Content-Type: application/json' --data-binary @"$T/s$k.json" "$URL/v1/render" >"$T/r$k.code" &
    CURLS[$k]=$!
done
full() { # every node holds one render, at its gate
    local i
    for i in 1 2 3; do node_gate_is $i held 1 && node_gate_is $i queued 1 || return 1; done
}
answered() { # N requests have their answer
    local n=0 k
    for k in $(seq 1 10); do [ -s "$T/r$k.code" ] && n=$((n + 1)); done
    [ "$n" = "$1" ]
}
wait_until 120 full
check busy_cluster_full "the nodes never held a render each: $(cat "$T"/g*.json)" full
wait_until 120 answered 7
check busy_seven_refused_while_full "$(cat "$T"/r*.code | tr '\n' ' ')" answered 7
refused_ok=1 why=""
for k in $(seq 1 10); do
    [ -s "$T/r$k.code" ] || continue
    c=$(cat "$T/r$k.code")
    ra=$(grep -i '^Retry-After:' "$T/r$k.head" | tr -d '\r' | sed 's/^[^:]*: *//')
    if [ "$c" != 503 ] || [ -z "$ra" ] || ! err_is "$T/r$k.body" 503 queue_full; then
        refused_ok=0 why+=" [$k: $c Retry-After='$ra' $(head -c 120 "$T/r$k.body")]"
    fi
done
check busy_503_json_retry_after "refused answers:$why" [ $refused_ok = 1 ]
for i in 1 2 3; do node_gate $i open; done
for k in $(seq 1 10); do wait "${CURLS[$k]}"; done
codes=$(for k in $(seq 1 10); do cat "$T/r$k.code"; echo; done | sort | uniq -c | tr -s ' \n' ' ')
n200=0 n503=0
for k in $(seq 1 10); do
    case $(cat "$T/r$k.code") in 200) n200=$((n200 + 1)) ;; 503) n503=$((n503 + 1)) ;; esac
done
check busy_only_200_or_503 "statuses: $codes" [ "$n200" = 3 -a "$n503" = 7 ]
pngs=1
for k in $(seq 1 10); do
    [ "$(cat "$T/r$k.code")" = 200 ] && ! is_png "$T/r$k.body" && pngs=0
done
check busy_accepted_are_pngs "a 200 without a PNG" [ $pngs = 1 ]
# each refused render was tried on all three nodes: none was skipped as failed
tried3=$(grep -c '"POST /v1/render HTTP/1.1" 503 .*ustatus=503, 503, 503 ' "$NG/log/access.log")
check busy_503_after_every_node "$tried3 of 7 refusals were tried on all 3 nodes: $(grep ' 503 ' "$NG/log/access.log" | head -n 3)" \
    [ "$tried3" = 7 ]
check busy_no_502 "nginx said 502/504: $(grep -E '" 50[24] ' "$NG/log/access.log" | head -n 2)" \
    bash -c "! grep -Eq '\" 50[24] ' '$NG/log/access.log'"

# --- the nodes that said 503 still get work -----------------------------------------
declare -A before
for i in 1 2 3; do before[$i]=$(node_count $i "POST /v1/render" 200); done
after_ok=1
for k in $(seq 1 6); do
    scene "$T/a$k.json" 48 32 1 spheres $((20 + k))
    [ "$(post_json /v1/render "$T/a$k.json" "${AUTH[@]}")" = 200 ] || after_ok=0
done
per="" spread=1
for i in 1 2 3; do
    n=$(($(node_count $i "POST /v1/render" 200) - before[$i])); per+=" node$i=$n"
    [ "$n" -ge 1 ] || spread=0
done
check after_busy_renders_ok "a render after the busy phase failed" [ $after_ok = 1 ]
check after_busy_no_node_ejected "renders per node after the 503s:$per" [ $spread = 1 ]

# --- jobs: created anywhere; a 404 is the answer, not retried ----------------------
# (these nodes have no --redis: a job stays on the node that took it; the
# any-node answers with Redis are tests/integration/cluster*.sh's)
for i in 1 2 3; do node_gate $i 0; done
scene "$T/j1.json" 48 32 1 spheres 41
code=$(post_json /v1/jobs "$T/j1.json" "${AUTH[@]}")
id=$(jfield "$T/body" id)
check jobs_created_through_nginx "$code $(head -c 200 "$T/body")" bash -c "[ '$code' = 202 ] && [ -n '$id' ]"
unknown=/v1/jobs/00000000000000000000000000000000
code=$(req GET "$unknown" "${AUTH[@]}")
unknown_ok() { [ "$code" = 404 ] && err_is "$T/body" 404 job_unknown; }
check jobs_unknown_404 "$code $(head -c 200 "$T/body")" unknown_ok
# the access log's upstream statuses: "ustatus=404 " (one node), not "404, 404, 404"
line=$(grep -F "\"GET $unknown HTTP/1.1\" 404 " "$NG/log/access.log" | tail -n 1)
check jobs_404_not_retried "access log: '$line'" bash -c "[[ '$line' == *'ustatus=404 cache='* ]]"
for i in 1 2 3; do     # the job's node stops it
    curl -s -m 60 -o /dev/null -X DELETE "${AUTH[@]}" "${NODE_URL[$i]}/v1/jobs/$id"
done
for i in 1 2 3; do node_gate $i open; done

# --- the tile cache and the token -----------------------------------------------------
scene "$T/c.json" 64 48 1 whitted 7
for i in 1 2 3; do     # every node learns the scene, so any may serve the tile
    curl -s -m 60 -o "$T/c$i.json" "${AUTH[@]}" -H 'Content-Type: application/json' \
        --data-binary @"$T/c.json" "${NODE_URL[$i]}/v1/scenes"
done
sid=$(jfield "$T/c1.json" id)
tile="/v1/scenes/$sid/image.png?x=0&y=0&w=32&h=32"
c1=$(req GET "$tile" "${AUTH[@]}"); x1=$(header X-Cache); vary=$(header Vary)
cp "$T/body" "$T/tile1.png"
check tile_vary_authorization "Vary: '$vary'" bash -c "[ $c1 = 200 ] && [[ '$vary' == *Authorization* ]]"
c2=$(req GET "$tile" "${AUTH[@]}"); x2=$(header X-Cache)
check tile_cached_with_token "first $c1 $x1, second $c2 $x2" \
    bash -c "[ $c2 = 200 ] && [ '$x2' = HIT ] && cmp -s '$T/body' '$T/tile1.png'"
c3=$(req GET "$tile"); x3=$(header X-Cache)
check tile_no_token_refused "without a token: $c3 $x3" bash -c "[ $c3 = 401 ] && [ '$x3' != HIT ]"
c4=$(req GET "$tile" -H "Authorization: Bearer not-$TOKEN"); x4=$(header X-Cache)
check tile_wrong_token_refused "another token: $c4 $x4" bash -c "[ $c4 = 401 ] && [ '$x4' != HIT ]"
nfiles=$(grep -rl "KEY: /v1/scenes/$sid/image.png" "$NG/cache/tiles" 2>/dev/null | wc -l)
check tile_in_cache "no cache file for the tile" [ "$nfiles" -ge 1 ]
check tile_cache_no_token "the token is in $(grep -rl -- "$TOKEN" "$NG/cache" | head -n 2)" \
    bash -c "! grep -rqa -- '$TOKEN' '$NG/cache'"

# --- every node down: nginx's own error is JSON with Retry-After, not HTML -----------
for i in 1 2 3; do kill -KILL "${NODE_PID[$i]}"; wait "${NODE_PID[$i]}" 2>/dev/null; done
code=$(post_json /v1/render "$T/s1.json" "${AUTH[@]}")
check down_json_502 "$code Retry-After='$(header Retry-After)' $(head -c 200 "$T/body")" \
    bash -c "[ $code = 502 ] && [ -n '$(header Retry-After)' ] &&
             python3 -c 'import json,sys; e=json.load(open(sys.argv[1]))[\"error\"]; sys.exit(e[\"code\"] != \"unavailable\")' '$T/body'"

nginx_stop_check_nodes 3
