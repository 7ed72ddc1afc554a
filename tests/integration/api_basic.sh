#!/usr/bin/env bash
# api_basic.sh -- the happy paths of every synchronous endpoint: health,
# metrics, the preview page, POST /v1/render (whole image and regions, byte
# for byte equal to rayd-render), POST /v1/scenes + GET image with ETag/304.
source "$(dirname "$0")/lib/common.sh"

start_rayd --threads 2
scene "$T/small.json" 160 120 1 spheres

# --- health, readiness, metrics, preview -------------------------------------
check healthz "not 200 ok" [ "$(req GET /healthz)" = 200 -a "$(json "$T/body" 'j["status"]')" = ok ]
check readyz "not 200 ready" [ "$(req GET /readyz)" = 200 -a "$(json "$T/body" 'j["status"]')" = ready ]
code=$(req GET /metrics)
check metrics_text "status $code or missing families" \
    grep -q '^# TYPE rayd_queue_wait_seconds histogram' "$T/body"
check metrics_families "missing render/cache/rejection/rays families" bash -c \
    "grep -q '^rayd_render_seconds_count' '$T/body' && grep -q '^rayd_cache_hits_total' '$T/body' && grep -q '^rayd_rejections_total{reason=\"queue_full\"}' '$T/body' && grep -q '^rayd_rays_total' '$T/body' && grep -q '^rayd_queue_depth' '$T/body'"
check metrics_content_type "$(header Content-Type)" bash -c "[[ '$(header Content-Type)' == text/plain* ]]"
code=$(req GET /)
check preview_page "status $code" bash -c "[ $code = 200 ] && grep -q '<textarea' '$T/body' && grep -q 'v1/render' '$T/body'"
check preview_type "$(header Content-Type)" bash -c "[[ '$(header Content-Type)' == text/html* ]]"
check preview_index_html "GET /index.html" [ "$(req GET /index.html)" = 200 ]

help=$("$RAYD" --help)
ok=1
for opt in bind port threads queue max-body max-pixels token-file cache-mb log-format log-level drain-seconds cors-origin; do
    grep -q -- "--$opt" <<<"$help" || { ok=0; echo "missing --$opt"; }
    env=RAYD_$(tr 'a-z-' 'A-Z_' <<<"$opt")
    grep -q -- "$env" <<<"$help" || { ok=0; echo "missing $env"; }
done
check help_documents_options "rayd --help lacks an option or its env" [ $ok = 1 ]
"$RAYD" --port nope >/dev/null 2>&1
check bad_option_exit "rayd --port nope did not fail" [ $? -ne 0 ]

# --- POST /v1/render: whole image ---------------------------------------------
"$RENDER" "$T/small.json" -o "$T/ref.png" 2>/dev/null
code=$(post_json /v1/render "$T/small.json")
cp "$T/body" "$T/full.png"
check render_full_200 "status $code" [ "$code" = 200 ]
check render_full_png "not a PNG" is_png "$T/full.png"
check render_full_type "$(header Content-Type)" [ "$(header Content-Type)" = image/png ]
check render_full_size "$(png_size "$T/full.png")" [ "$(png_size "$T/full.png")" = 160x120 ]
check render_full_equals_cli "differs from rayd-render" cmp -s "$T/full.png" "$T/ref.png"

# --- regions --------------------------------------------------------------------
for r in "0,0,64,64" "10,20,33,17" "96,56,64,64" "159,119,1,1" "0,0,160,120"; do
    IFS=, read -r x y w h <<<"$r"
    "$RENDER" "$T/small.json" -o "$T/ref_r.png" --region "$r" 2>/dev/null
    code=$(post_json "/v1/render?x=$x&y=$y&w=$w&h=$h" "$T/small.json")
    check "region_${x}_${y}_${w}_${h}_status" "status $code" [ "$code" = 200 ]
    check "region_${x}_${y}_${w}_${h}_size" "$(png_size "$T/body")" [ "$(png_size "$T/body")" = "${w}x${h}" ]
    check "region_${x}_${y}_${w}_${h}_equals_cli" "differs from rayd-render --region $r" cmp -s "$T/body" "$T/ref_r.png"
done

# a region of a bigger image spans several 64-pixel tiles of the workers
scene "$T/mid.json" 300 200 1 whitted
"$RENDER" "$T/mid.json" -o "$T/ref_mid.png" --region 37,11,200,150 2>/dev/null
code=$(post_json "/v1/render?x=37&y=11&w=200&h=150" "$T/mid.json")
check region_multi_tile_equals_cli "status $code or bytes differ" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/ref_mid.png'"

# --- POST /v1/scenes + GET image ----------------------------------------------------
code=$(post_json /v1/scenes "$T/small.json")
id=$(json "$T/body" 'j["id"]')
check scenes_post_201 "status $code" [ "$code" = 201 ]
check scenes_id_is_sha256 "id $id" [ "$id" = "$(sha256sum "$T/small.json" | cut -d' ' -f1)" ]
check scenes_location "$(header Location)" [ "$(header Location)" = "/v1/scenes/$id" ]
# the Location names something: the scene's JSON, with its image's URL
code=$(req GET "/v1/scenes/$id")
got="$(json "$T/body" 'j["image_url"]') $(json "$T/body" 'j["width"]')"
check scenes_location_answers "status $code $(head -c 300 "$T/body")" \
    [ "$code $got" = "200 /v1/scenes/$id/image.png 160" ]
code=$(req GET "/v1/scenes/0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef")
check scenes_get_unknown "status $code" bash -c "[ $code = 404 ] && grep -q scene_unknown '$T/body'"
code=$(req GET "/v1/scenes/$id/image.png")
etag=$(header ETag)
check scene_image_200 "status $code" [ "$code" = 200 ]
check scene_image_equals_cli "differs" cmp -s "$T/body" "$T/ref.png"
check scene_image_etag_strong "ETag '$etag'" bash -c "[[ '$etag' =~ ^\\\"[0-9a-f]{64}\\\"$ ]]"
check scene_image_cache_control "$(header Cache-Control)" [ "$(header Cache-Control)" = "public, max-age=31536000, immutable" ]
code=$(req GET "/v1/scenes/$id/image.png" -H "If-None-Match: $etag")
check scene_image_304 "status $code" [ "$code" = 304 ]
check scene_image_304_empty "body not empty" [ ! -s "$T/body" ]
check scene_image_304_etag "$(header ETag)" [ "$(header ETag)" = "$etag" ]
code=$(req GET "/v1/scenes/$id/image.png" -H 'If-None-Match: "other"')
check scene_image_etag_mismatch_200 "status $code" [ "$code" = 200 ]
code=$(req GET "/v1/scenes/$id/image.png?x=10&y=20&w=33&h=17")
"$RENDER" "$T/small.json" -o "$T/ref_r.png" --region 10,20,33,17 2>/dev/null
rtag=$(header ETag)
check scene_region_equals_cli "status $code or bytes differ" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/ref_r.png'"
check scene_region_own_etag "same ETag as the whole image" [ "$rtag" != "$etag" ]
code=$(req GET "/v1/scenes/$id/image.png?x=10&y=20&w=33&h=17" -H "If-None-Match: W/$rtag, \"x\"")
check scene_region_304_list "status $code" [ "$code" = 304 ]
code=$(req HEAD "/v1/scenes/$id/image.png" -I)
check scene_image_head "status $code" [ "$code" = 200 ]

# --- the scene cache: the second POST of the same bytes is a hit -------------------
h0=$(metric rayd_cache_hits_total)
post_json /v1/render "$T/small.json" >/dev/null
h1=$(metric rayd_cache_hits_total)
check cache_hit_counted "hits $h0 -> $h1" [ "$h1" -gt "$h0" ]

# --- finished PNGs are served again without a render --------------------------------
r0=$(metric rayd_render_seconds_count); x0=$(metric rayd_result_cache_hits_total)
post_json "/v1/render?x=1&y=2&w=50&h=40" "$T/small.json" >/dev/null; cp "$T/body" "$T/rc1.png"
post_json "/v1/render?x=1&y=2&w=50&h=40" "$T/small.json" >/dev/null
r1=$(metric rayd_render_seconds_count); x1=$(metric rayd_result_cache_hits_total)
check result_cache_hit "renders $r0 -> $r1, hits $x0 -> $x1" bash -c "[ $r1 = $((r0 + 1)) ] && [ $x1 = $((x0 + 1)) ]"
check result_cache_same_bytes "cached answer differs" cmp -s "$T/body" "$T/rc1.png"

# --- access log -----------------------------------------------------------------
# (a line is written once its response has gone out: wait for it)
wait_until 30 grep -Eq 'POST /v1/render 200 [0-9]+ queue_ms=' "$T/rayd.err"
check access_log_line "no access line for POST /v1/render 200" \
    grep -Eq 'POST /v1/render 200 [0-9]+ queue_ms=[0-9.]+ render_ms=[0-9.]+' "$T/rayd.err"
check metrics_by_route "no POST /v1/render 200 counter" \
    bash -c "curl -s '$URL/metrics' | grep -q 'rayd_http_requests_total{route=\"/v1/render\",method=\"POST\",code=\"200\"}'"
# every stage of a request's wait has its histogram, each counted by now
stages_ok=1
for st in upload parse decode build queue render encode send; do
    n=$(metric "rayd_stage_seconds_count{stage=\"$st\"}")
    [ "${n:-0}" -ge 1 ] || { stages_ok=0; echo "stage $st counted '${n}'"; }
done
check metrics_stage_histograms "a stage not counted" [ $stages_ok = 1 ]
check access_log_encode_ms "no encode_ms in the access line" \
    grep -Eq 'POST /v1/render 200 [0-9]+ queue_ms=[0-9.]+ render_ms=[0-9.]+ encode_ms=[0-9.]+' "$T/rayd.err"

stop_rayd TERM
check exit_0_on_term "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
check stdout_one_line "stdout has $(wc -l <"$T/rayd.out") lines" [ "$(wc -l <"$T/rayd.out")" = 1 ]

# --- json log format ---------------------------------------------------------------
start_rayd --log-format json
req GET /healthz >/dev/null
wait_until 30 grep -q '"/healthz"' "$T/rayd.err"
check log_json "no JSON access line, or a line that is not JSON" python3 -c '
import json, sys
found = False
for l in open(sys.argv[1]):
    d = json.loads(l)  # every line of the log is JSON
    if d.get("path") == "/healthz" and d.get("status") == 200 and d.get("level") == "info" and "total_ms" in d and "bytes" in d and d.get("client") == "127.0.0.1" and d.get("request_id"): found = True
sys.exit(0 if found else 1)' "$T/rayd.err"
stop_rayd TERM
# --- without the result cache, GET of a scene image renders ---------------------------
start_rayd --result-cache-mb 0
post_json /v1/scenes "$T/small.json" >/dev/null
for k in 1 2; do
    code=$(req GET "/v1/scenes/$id/image.png?x=10&y=20&w=33&h=17")
done
check no_result_cache_renders "status $code, renders $(metric rayd_render_seconds_count)" \
    bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/ref_r.png' && [ \"\$(curl -s '$URL/metrics' | awk '\$1==\"rayd_render_seconds_count\"{print \$2}')\" = 2 ]"
# with the cache off nothing is looked up: no hit and no miss is counted
check no_result_cache_no_misses "misses $(metric rayd_result_cache_misses_total), hits $(metric rayd_result_cache_hits_total)" \
    bash -c "[ '$(metric rayd_result_cache_misses_total)' = 0 ] && [ '$(metric rayd_result_cache_hits_total)' = 0 ]"
stop_rayd TERM
# --- one header of a name: a reply's layers (the JSON, the error, the route) each
# setting Cache-Control said it twice on the job list and an unknown job's 404
start_rayd
post_json /v1/jobs "$T/small.json" >/dev/null
for route in "GET /v1/jobs" "HEAD /v1/jobs" "GET /v1/jobs?limit=1" \
    "GET /v1/jobs/0123456789abcdef0123456789abcdef" "GET /v1/health" "GET /v1/no-such-route"; do
    method=${route%% *} path=${route#* }
    if [ "$method" = HEAD ]; then req HEAD "$path" -I >/dev/null; else req "$method" "$path" >/dev/null; fi
    twice=$(tr -d '\r' <"$T/headers" | grep -o '^[A-Za-z-]*:' | tr 'A-Z' 'a-z' | sort | uniq -d | tr '\n' ' ')
    check "one_header_each ${route}" "said twice: $twice" [ -z "$twice" ]
done
stop_rayd TERM
# --- environment ------------------------------------------------------------------
RAYD_QUEUE=7 start_rayd
check env_option "RAYD_QUEUE ignored" [ "$(metric rayd_queue_capacity)" = 7 ]
stop_rayd TERM
