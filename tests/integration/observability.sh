#!/usr/bin/env bash
# observability.sh -- what an operator reads: the access log (its fields for a
# tile render with a query, text and JSON, a hostile path still one valid
# line, --log-level filtering by the status's level), X-Request-Id (echoed
# when sane, made up otherwise, the same in the header and the log), the
# metrics (route/method/code labels, rayd_build_info, process_*, buckets up
# to --max-render-seconds, the exposition read by the Prometheus client's own
# parser, HELP and TYPE for every family), and RFC 9110 304s (no body, no
# Content-Length, the 200's ETag and Cache-Control).
source "$(dirname "$0")/lib/common.sh"

# A Python with prometheus_client (Debian's python3-prometheus-client lives
# in /usr/bin/python3, which may not be the python3 first on PATH).
PYPROM=
for py in python3 /usr/bin/python3; do
    if "$py" -c 'import prometheus_client.parser' 2>/dev/null; then PYPROM=$py; break; fi
done

scene "$T/s.json" 96 64 1 spheres
t_before=$(date +%s)
start_rayd --threads 2
T_STARTED=$t_before

# --- a tile render with a query string: every field of its access line --------
post_json /v1/scenes "$T/s.json" >/dev/null
id=$(json "$T/body" 'j["id"]')
tile="/v1/scenes/$id/image.png?x=8&y=4&w=32&h=24"
code=$(req GET "$tile" -H 'X-Request-Id: obs-tile-1')
cp "$T/headers" "$T/tile.h"
tile_bytes=$(stat -c %s "$T/body")
check tile_200 "status $code" [ "$code" = 200 ]
check request_id_echoed "X-Request-Id '$(header X-Request-Id)'" [ "$(header X-Request-Id)" = obs-tile-1 ]
wait_until 30 grep -q 'request_id=obs-tile-1' "$T/rayd.err"
check access_text_fields "$(grep 'request_id=obs-tile-1' "$T/rayd.err")" python3 - "$T/rayd.err" "$id" "$tile" "$tile_bytes" <<'PY'
import datetime, re, sys
path, sid, target, nbytes = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
line = [l for l in open(path) if "request_id=obs-tile-1" in l][0].rstrip("\n")
m = re.fullmatch(r"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z) info 127\.0\.0\.1 GET (\S+) 200 (\d+) "
                 r"queue_ms=[0-9.]+ render_ms=([0-9.]+) encode_ms=[0-9.]+ total_ms=([0-9.]+) "
                 r"scene=([0-9a-f]{64}) request_id=obs-tile-1", line)
assert m, line
datetime.datetime.strptime(m[1], "%Y-%m-%dT%H:%M:%S.%fZ")
assert m[2] == target, (m[2], target)           # the query is in the path
assert m[3] == nbytes, (m[3], nbytes)           # the body's bytes
assert float(m[5]) >= float(m[4]) > 0           # total covers the render
assert m[6] == sid
PY

# --- request ids: made up when absent or insane, header and log agree --------
code=$(req GET /healthz)
rid=$(header X-Request-Id)
check request_id_generated "'$rid'" bash -c "[[ '$rid' =~ ^[0-9a-f]{32}$ ]]"
code=$(req GET /healthz)
check request_id_unique "two requests got '$rid' and '$(header X-Request-Id)'" [ "$(header X-Request-Id)" != "$rid" ]
code=$(req GET /healthz -H 'X-Request-Id: bad id "with" spaces')
rid2=$(header X-Request-Id)
check request_id_insane_replaced "'$rid2'" bash -c "[[ '$rid2' =~ ^[0-9a-f]{32}$ ]]"
code=$(req GET /healthz -H "X-Request-Id: $(printf 'a%.0s' $(seq 1 65))")
check request_id_too_long_replaced "'$(header X-Request-Id)'" bash -c "[[ '$(header X-Request-Id)' =~ ^[0-9a-f]{32}$ ]]"
wait_until 30 grep -q "request_id=$rid2" "$T/rayd.err"
check request_id_logged "no line with request_id=$rid2" grep -q "GET /healthz 200 .*request_id=$rid2\$" "$T/rayd.err"
code=$(req GET /nope-404 -H 'X-Request-Id: obs-404')
check request_id_on_errors "404 without its id" [ "$code" = 404 -a "$(header X-Request-Id)" = obs-404 ]
wait_until 30 grep -q 'request_id=obs-404' "$T/rayd.err"
check level_warn_for_4xx "$(grep 'request_id=obs-404' "$T/rayd.err")" \
    grep -Eq '^[0-9T:.-]+Z warn 127\.0\.0\.1 GET /nope-404 404 [0-9]+ total_ms=[0-9.]+ request_id=obs-404 error=not_found$' "$T/rayd.err"
# an error's line says what was wrong and where: the code, and the JSON
# Pointer (or query parameter) the answer names
printf '{"objects": [{"type": "sphere"}, {"type": "sphere", "radius": 0}]}' >"$T/bad-radius.json"
post_json /v1/render "$T/bad-radius.json" -H 'X-Request-Id: obs-422' >/dev/null
printf '{}' >"$T/empty-scene.json"
post_json "/v1/render?x=0&y=0&w=0&h=1" "$T/empty-scene.json" -H 'X-Request-Id: obs-400' >/dev/null
wait_until 30 grep -q 'request_id=obs-400' "$T/rayd.err"
check access_error_pointer "$(grep 'request_id=obs-422' "$T/rayd.err")" \
    grep -Eq ' POST /v1/render 422 .* request_id=obs-422 error=invalid_scene error_at=/objects/1/radius$' "$T/rayd.err"
check access_error_parameter "$(grep 'request_id=obs-400' "$T/rayd.err")" \
    grep -Eq ' 400 .* request_id=obs-400 error=bad_region error_at=w$' "$T/rayd.err"

# --- 304: no body, no Content-Length, the 200's ETag and Cache-Control --------
etag=$(grep -i '^etag:' "$T/tile.h" | sed 's/^[^:]*: *//; s/\r$//')
cc=$(grep -i '^cache-control:' "$T/tile.h" | sed 's/^[^:]*: *//; s/\r$//')
check etag_on_200 "no ETag on the tile" [ -n "$etag" ]
check not_modified_raw "see above" python3 - "$PORT" "$tile" "$etag" "$cc" <<'PY'
import socket, sys
port, target, etag, cc = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4]
for method in ("GET", "HEAD"):
    s = socket.create_connection(("127.0.0.1", port), timeout=60)
    s.sendall(("%s %s HTTP/1.1\r\nHost: x\r\nIf-None-Match: %s\r\n\r\n" % (method, target, etag)).encode())
    data = b""
    while True:  # rayd closes the connection after a 304: read to the end
        chunk = s.recv(65536)
        if not chunk:
            break
        data += chunk
    head, sep, body = data.partition(b"\r\n\r\n")
    lines = head.decode().split("\r\n")
    hdrs = {l.split(":", 1)[0].lower(): l.split(":", 1)[1].strip() for l in lines[1:]}
    ok = (sep and lines[0].startswith("HTTP/1.1 304") and body == b"" and
          "content-length" not in hdrs and "transfer-encoding" not in hdrs and
          hdrs.get("etag") == etag and hdrs.get("cache-control") == cc and hdrs.get("x-request-id"))
    if not ok:
        print("%s: %r" % (method, data))
        sys.exit(1)
PY
code=$(req GET "$tile" -H "If-None-Match: $etag")
check not_modified_curl "status $code, $(stat -c %s "$T/body") body bytes" \
    bash -c "[ $code = 304 ] && [ ! -s '$T/body' ] && ! grep -qi '^content-length' '$T/headers'"

# --- metrics: labels, families, process_*, build info, buckets ----------------
req PUT /v1/jobs/0123 >/dev/null
curl -s -m 30 -o /dev/null -X BREW "$URL/healthz"
# CPU ticks of rayd (utime + stime, fields 14 and 15 of /proc/PID/stat)
ticks() { sed 's/.*) //' "/proc/$RAYD_PID/stat" | awk '{print $12 + $13}'; }
ticks_before=$(ticks)
code=$(req GET /metrics)
cp "$T/body" "$T/metrics.txt"
ticks_after=$(ticks)
now=$(date +%s)
m() { awk -v k="$1" '$1 == k {print $2}' "$T/metrics.txt"; }
check metrics_200 "status $code" [ "$code" = 200 ]
check http_requests_labels "no tile series" \
    [ "$(m 'rayd_http_requests_total{route="/v1/scenes/{id}/image.png",method="GET",code="200"}')" = 1 ]
check http_requests_304 "304 count '$(m 'rayd_http_requests_total{route="/v1/scenes/{id}/image.png",method="GET",code="304"}')'" \
    [ "$(m 'rayd_http_requests_total{route="/v1/scenes/{id}/image.png",method="GET",code="304"}')" = 2 ]
check http_requests_head "HEAD 304 not counted" \
    [ "$(m 'rayd_http_requests_total{route="/v1/scenes/{id}/image.png",method="HEAD",code="304"}')" = 1 ]
check http_requests_405 "PUT 405 not under its pattern" \
    [ "$(m 'rayd_http_requests_total{route="/v1/jobs/{id}",method="PUT",code="405"}')" = 1 ]
check http_requests_unknown_method "BREW not counted as method=other" \
    [ "$(m 'rayd_http_requests_total{route="/healthz",method="other",code="405"}')" = 1 ]
check http_requests_unmatched "404 not under route=none" \
    [ "$(m 'rayd_http_requests_total{route="none",method="GET",code="404"}')" = 1 ]
check http_duration_count "duration count != request count" \
    [ "$(m 'rayd_http_request_duration_seconds_count{route="/v1/scenes/{id}/image.png",method="GET",code="200"}')" = 1 ]
check route_is_pattern "a route label holds a raw id or an old-style label" \
    bash -c "! grep -Eq 'route=\"([A-Z]+ |[^\"]*[0-9a-f]{32})' '$T/metrics.txt' && ! grep -Eq '^rayd_requests_total|status=\"' '$T/metrics.txt'"
version=$("$RAYD" --version | awk '{print $2}')
check build_info "no rayd_build_info for $version" \
    grep -Eq "^rayd_build_info\\{version=\"$version\",compiler=\"(gcc|clang) [^\"]+\"\\} 1\$" "$T/metrics.txt"
check buckets_to_3600 "no le=\"3600\" on the render histogram" \
    bash -c "grep -q '^rayd_render_seconds_bucket{le=\"3600\"}' '$T/metrics.txt' && grep -q '^rayd_queue_wait_seconds_bucket{class=\"bulk\",le=\"3600\"}' '$T/metrics.txt'"
check process_metrics "implausible process_* values" python3 - "$T/metrics.txt" "$RAYD_PID" "$T_STARTED" "$now" \
    "$ticks_before" "$ticks_after" "$(getconf CLK_TCK)" <<'PY'
import sys
text, pid, started, now = open(sys.argv[1]).read(), sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
t0, t1, hz = float(sys.argv[5]), float(sys.argv[6]), float(sys.argv[7])
v = {l.split()[0]: float(l.split()[1]) for l in text.splitlines() if l.startswith("process_")}
limits = [l for l in open("/proc/%s/limits" % pid) if l.startswith("Max open files")][0].split()
soft = float(limits[3]) if limits[3] != "unlimited" else 1e18
problems = []
# the CPU time lies between two readings of /proc/PID/stat taken around the scrape
if not (min(t0, t1) / hz - 0.011 <= v["process_cpu_seconds_total"] <= max(t0, t1) / hz + 0.011):
    problems.append("cpu %s not in [%s, %s]" % (v["process_cpu_seconds_total"], t0 / hz, t1 / hz))
if not (1 << 20 < v["process_resident_memory_bytes"] <= v["process_virtual_memory_bytes"]):
    problems.append("memory rss %s vsz %s" % (v["process_resident_memory_bytes"], v["process_virtual_memory_bytes"]))
if not (3 <= v["process_open_fds"] <= v["process_max_fds"]):
    problems.append("fds %s of %s" % (v["process_open_fds"], v["process_max_fds"]))
if v["process_max_fds"] != soft:
    problems.append("max_fds %s, /proc says %s" % (v["process_max_fds"], soft))
# started after the test began (btime has whole seconds) and before the scrape
if not (started - 1.5 <= v["process_start_time_seconds"] <= now + 1):
    problems.append("start %s not in [%s, %s]" % (v["process_start_time_seconds"], started, now))
print("; ".join(problems))
sys.exit(1 if problems else 0)
PY
check help_and_type_everywhere "a family without HELP or TYPE" python3 - "$T/metrics.txt" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
helps = set(re.findall(r"^# HELP (\S+) \S", text, re.M))
types = dict(re.findall(r"^# TYPE (\S+) (\S+)$", text, re.M))
bad = []
for line in text.splitlines():
    if line.startswith("#") or not line:
        continue
    name = re.match(r"[a-zA-Z_:][a-zA-Z0-9_:]*", line)[0]
    fam = name
    if fam not in types:
        fam = re.sub(r"_(bucket|sum|count)$", "", name)
    if fam not in types or fam not in helps:
        bad.append(name)
print(sorted(set(bad)))
sys.exit(1 if bad else 0)
PY
if [ -n "$PYPROM" ]; then
    check exposition_parses "prometheus_client's parser refused it" "$PYPROM" - "$T/metrics.txt" <<'PY'
import sys
from prometheus_client.parser import text_string_to_metric_families
fams = list(text_string_to_metric_families(open(sys.argv[1]).read()))
names = {f.name: f for f in fams}
bad = []
for want, typ in [("rayd_http_requests", "counter"), ("rayd_http_request_duration_seconds", "histogram"),
                  ("rayd_build_info", "gauge"), ("process_cpu_seconds", "counter"),
                  ("process_resident_memory_bytes", "gauge"), ("process_virtual_memory_bytes", "gauge"),
                  ("process_open_fds", "gauge"), ("process_max_fds", "gauge"),
                  ("process_start_time_seconds", "gauge"), ("rayd_render_seconds", "histogram")]:
    if want not in names or names[want].type != typ:
        bad.append(want)
for f in fams:
    if f.type == "unknown" or not f.documentation:
        bad.append(f.name + " untyped or undocumented")
    if f.type == "histogram":  # buckets cumulative, +Inf equal to the count
        series = {}
        for s in f.samples:
            key = tuple(sorted((k, v) for k, v in s.labels.items() if k != "le"))
            series.setdefault(key, {"b": [], "count": None})
            if s.name.endswith("_bucket"):
                series[key]["b"].append((float(s.labels["le"]), s.value))
            elif s.name.endswith("_count"):
                series[key]["count"] = s.value
        for key, d in series.items():
            vals = [v for _, v in sorted(d["b"])]
            if vals != sorted(vals) or not d["b"] or sorted(d["b"])[-1][0] != float("inf") or vals[-1] != d["count"]:
                bad.append("%s%s buckets" % (f.name, key))
print(bad)
sys.exit(1 if bad else 0)
PY
else
    fail exposition_parses "no python3 with prometheus_client (Debian python3-prometheus-client; make deps)"
fi
stop_rayd TERM
cp "$T/rayd.err" "$T/rayd.err.info" # the default level rendered a tile

# --- JSON lines: a hostile path is still one valid JSON object -----------------
start_rayd --log-format json
post_json /v1/scenes "$T/s.json" >/dev/null
req GET "$tile" -H 'X-Request-Id: obs-json-1' >/dev/null
python3 - "$PORT" <<'PY'
import socket, sys
for target in [b'/a"b\\c?q="x\\y"&t=\x01z', b'/q\xff\xfe"?x=\x7f', b'/ctl\x01\x1b"\\u0000']:
    s = socket.create_connection(("127.0.0.1", int(sys.argv[1])), timeout=60)
    s.sendall(b"GET " + target + b" HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
    while s.recv(65536):
        pass
PY
stop_rayd TERM
check json_lines_valid "see above" python3 - "$T/rayd.err" "$id" "$tile" <<'PY'
import json, sys
raw = open(sys.argv[1], "rb").read()
lines = [json.loads(l.decode("utf-8")) for l in raw.split(b"\n") if l]  # strict UTF-8, every line JSON
paths = [d.get("path") for d in lines]
want = ['/a"b\\c?q="x\\y"&t=%01z', '/q%FF%FE"?x=%7F', '/ctl%01%1B"\\u0000']
missing = [w for w in want if w not in paths]
tile = [d for d in lines if d.get("request_id") == "obs-json-1"]
ok = not missing and len(tile) == 1
if ok:
    t = tile[0]
    ok = (t["level"] == "info" and t["client"] == "127.0.0.1" and t["method"] == "GET" and
          t["path"] == sys.argv[3] and t["status"] == 200 and t["bytes"] > 0 and t["scene"] == sys.argv[2] and
          "total_ms" in t and "render_ms" in t and t["time"].endswith("Z"))
    hostile = [d for d in lines if d.get("path") in want]
    # (control bytes in a target are 400 bad_request: RFC 9112 framing)
    ok = ok and all(d["level"] == "warn" and d["status"] == 400 for d in hostile)
print(missing, tile)
sys.exit(0 if ok else 1)
PY

# --- --log-level: lines below the level are not written ------------------------
scene "$T/held.json" 96 64 1 spheres 7
start_rayd --log-level warn --max-render-seconds 100
req GET /healthz -H 'X-Request-Id: lvl-200' >/dev/null
req GET /nope -H 'X-Request-Id: lvl-404' >/dev/null
code=$(req GET /metrics)
check buckets_end_at_max_render "le=100 missing or le=3600 present" \
    bash -c "grep -q '^rayd_render_seconds_bucket{le=\"100\"}' '$T/body' && ! grep -q 'le=\"3600\"' '$T/body' && grep -q '^rayd_render_seconds_bucket{le=\"60\"}' '$T/body'"
stop_rayd TERM
check level_warn_drops_info "an info line was written" bash -c "! grep -q ' info ' '$T/rayd.err' && ! grep -q 'lvl-200' '$T/rayd.err'"
check level_warn_keeps_4xx "no 404 line" grep -q 'warn 127.0.0.1 GET /nope 404 .*request_id=lvl-404 error=not_found$' "$T/rayd.err"

start_rayd --log-level error --queue 1 --test-gate 0 --max-render-seconds 7200
post_json /v1/jobs "$T/held.json" -H 'X-Request-Id: lvl-202' >/dev/null
job=$(json "$T/body" 'j["id"]')
wait_until 60 metric_is rayd_queue_depth 1
code=$(req GET /readyz -H 'X-Request-Id: lvl-503')
check readyz_503_when_full "status $code" [ "$code" = 503 ]
req GET /nope -H 'X-Request-Id: lvl-404' >/dev/null
code=$(req GET /metrics)
check buckets_past_3600 "no le=3600 then le=7200" \
    bash -c "grep -q '^rayd_queue_wait_seconds_bucket{class=\"bulk\",le=\"3600\"}' '$T/body' && grep -q '^rayd_queue_wait_seconds_bucket{class=\"bulk\",le=\"7200\"}' '$T/body'"
req DELETE "/v1/jobs/$job" >/dev/null
gate open
stop_rayd TERM
check level_error_keeps_5xx "no error line for the 503" grep -q 'error 127.0.0.1 GET /readyz 503 .*request_id=lvl-503 error=queue_full$' "$T/rayd.err"
check level_error_drops_rest "a 2xx/4xx or info line was written" \
    bash -c "! grep -Eq 'lvl-202|lvl-404| info | warn ' '$T/rayd.err'"

"$RAYD" --log-level loud >/dev/null 2>"$T/bad.err"
rc=$?
check bad_log_level_refused "rayd --log-level loud: status $rc, $(cat "$T/bad.err")" \
    bash -c "[ $rc -ne 0 ] && grep -q 'log-level' '$T/bad.err'"
start_rayd --log-level debug
req GET /healthz -H 'X-Request-Id: lvl-debug' >/dev/null
post_json "/v1/render?x=0&y=0&w=8&h=8" "$T/s.json" >/dev/null
stop_rayd TERM
check level_debug_keeps_info "no info lines at debug" \
    bash -c "grep -q ' info rayd ' '$T/rayd.err' && grep -q 'request_id=lvl-debug' '$T/rayd.err'"
check level_debug_lines "no debug line for the render" grep -q ' debug render .* finished: ok' "$T/rayd.err"
check level_info_no_debug "a debug line at the default level" bash -c "! grep -q ' debug ' '$T/rayd.err.info'"

exit 0
