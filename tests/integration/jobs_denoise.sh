#!/usr/bin/env bash
# jobs_denoise.sh -- POST /v1/jobs?denoise=0|1 and ?aov=: a plain job's PNG
# and EXR, each frame of a frame-range job and each pass of a progressive
# job are the bytes rayd-render --denoise writes for the same scene, frame
# and samples; a progressive pass stays there raw (?denoise=0, the bytes of
# the plain render); the scene's render.denoise is the default; ?aov= as
# POST /v1/render takes it; bad values 400 naming the parameter, images a
# job did not keep 409; a denoised render whose apron and filter buffers do
# not fit --max-memory refused 413 while its raw render fits; with
# --data-dir, a job queued at a kill -9 renders denoised after the restart.
source "$(dirname "$0")/lib/common.sh"

start_rayd --threads 2
scene "$T/c.json" 120 90 4 cornell

# wait_job ID: the job ended (its JSON in $T/body)
job_ended() { req GET "/v1/jobs/$1" >/dev/null && grep -q '"state":"\(succeeded\|failed\|canceled\)"' "$T/body"; }
# post_job QUERY FILE: the new job's id (the 202's body in $T/post.json)
post_job() {
    post_json "/v1/jobs?$1" "$2" >/dev/null
    cp "$T/body" "$T/post.json"
    jfield "$T/post.json" id
}

"$RENDER" "$T/c.json" -o "$T/d.png" --denoise --threads 1 -q
"$RENDER" "$T/c.json" -o "$T/d.exr" --denoise --threads 2 -q
"$RENDER" "$T/c.json" -o "$T/raw.png" --threads 1 -q

# ---- a plain job: its PNG and EXR denoised -------------------------------------------
id=$(post_job "denoise=1&format=exr" "$T/c.json")
check plain_202_says_denoise "$(cat "$T/post.json")" grep -q '"denoise":true' "$T/post.json"
wait_until 60 job_ended "$id"
code=$(req GET "/v1/jobs/$id/image.png")
check plain_png_equals_cli "status $code or differs from rayd-render --denoise" \
    bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/d.png'"
code=$(req GET "/v1/jobs/$id/image.exr")
check plain_exr_equals_cli "status $code or differs" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/d.exr'"
code=$(req GET "/v1/jobs/$id/image.png?denoise=1")
check plain_denoise_1_is_image "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/d.png'"
code=$(req GET "/v1/jobs/$id/image.png?denoise=0")
check plain_raw_not_kept "status $code $(cat "$T/body")" \
    bash -c "[ $code = 409 ] && grep -q raw_not_kept '$T/body'"
# a progressive job whose PNG is an AOV keeps no raw passes: the 409 says
# so, not "a progressive job keeps each pass raw" of a job that is one
id=$(post_job "progressive=1&denoise=1&aov=depth" "$T/c.json")
wait_until 60 job_ended "$id"
code=$(req GET "/v1/jobs/$id/image.png?denoise=0")
check aov_progressive_raw_not_kept "status $code $(cat "$T/body")" \
    bash -c "[ $code = 409 ] && grep -q raw_not_kept '$T/body' && grep -q 'shows an AOV' '$T/body'"

id=$(post_job "" "$T/c.json")
wait_until 60 job_ended "$id"
code=$(req GET "/v1/jobs/$id/image.png")
check raw_job_unchanged "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/raw.png'"
check raw_job_json_no_denoise "$(cat "$T/post.json")" bash -c "! grep -q denoise '$T/post.json'"
code=$(req GET "/v1/jobs/$id/image.png?denoise=1")
check raw_job_not_denoised "status $code $(cat "$T/body")" \
    bash -c "[ $code = 409 ] && grep -q not_denoised '$T/body'"
code=$(req GET "/v1/jobs/$id/image.png?denoise=0")
check raw_job_denoise_0_is_image "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/raw.png'"

# ---- the scene's render.denoise as the default ---------------------------------------
python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); s["render"]["denoise"]=True; print(json.dumps(s))' "$T/c.json" >"$T/cd.json"
id=$(post_job "" "$T/cd.json")
wait_until 60 job_ended "$id"
code=$(req GET "/v1/jobs/$id/image.png")
check scene_default_denoised "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/d.png'"
id=$(post_job "denoise=0" "$T/cd.json")
wait_until 60 job_ended "$id"
code=$(req GET "/v1/jobs/$id/image.png")
check scene_denoise_0_raw "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/raw.png'"

# ---- ?aov=: one AOV as the PNG; with format=exr the EXR's channels -----------------
post_json "/v1/render?aov=depth" "$T/c.json" >/dev/null
cp "$T/body" "$T/depth.png"
post_json "/v1/render?format=exr&aov=albedo,normal" "$T/c.json" >/dev/null
cp "$T/body" "$T/aov.exr"
id=$(post_job "aov=depth" "$T/c.json")
wait_until 60 job_ended "$id"
code=$(req GET "/v1/jobs/$id/image.png")
check aov_png_equals_render "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/depth.png'"
id=$(post_job "format=exr&aov=albedo,normal" "$T/c.json")
wait_until 60 job_ended "$id"
code=$(req GET "/v1/jobs/$id/image.exr")
check aov_exr_equals_render "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/aov.exr'"
code=$(req GET "/v1/jobs/$id/image.png")
check aov_exr_job_png_is_light "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/raw.png'"

# ---- a progressive job: each pass denoised, and raw ------------------------------------
for n in 1 2 4; do
    scene "$T/p$n.json" 120 90 $n cornell
    "$RENDER" "$T/p$n.json" -o "$T/pd$n.png" --denoise --threads 2 -q
    "$RENDER" "$T/p$n.json" -o "$T/pr$n.png" --threads 2 -q
done
id=$(post_job "progressive=1&denoise=1" "$T/c.json")
curl -s -N -m 60 "$URL/v1/jobs/$id/events" >"$T/sse.txt"
check prog_pass_events_raw_url "$(head -c 600 "$T/sse.txt")" env PYTHONPATH="$SSE_LIB" python3 -c '
import json, sys
import sse
p = [json.loads(e["data"]) for e in sse.events(sys.argv[1]) if e.get("event") == "pass"]
ok = [q["pass"] for q in p] == [1, 2, 3]
ok = ok and all(q["raw_url"] == q["image_url"] + "&denoise=0" for q in p)
sys.exit(0 if ok else 1)' "$T/sse.txt"
wait_until 60 job_ended "$id"
for k in 1 2 3; do
    n=$((1 << (k - 1)))
    code=$(req GET "/v1/jobs/$id/image.png?pass=$k")
    check "pass_${k}_denoised_equals_cli" "status $code, X-Rayd-Samples $(header X-Rayd-Samples)" \
        bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Samples)' = $n ] && cmp -s '$T/body' '$T/pd$n.png'"
    code=$(req GET "/v1/jobs/$id/image.png?pass=$k&denoise=0")
    check "pass_${k}_raw_equals_plain" "status $code" \
        bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Samples)' = $n ] && cmp -s '$T/body' '$T/pr$n.png'"
done
code=$(req GET "/v1/jobs/$id/image.png")
check prog_final_denoised "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/d.png'"
code=$(req GET "/v1/jobs/$id/image.png?denoise=0")
check prog_final_raw "status $code pass $(header X-Rayd-Pass)" \
    bash -c "[ $code = 200 ] && [ '$(header X-Rayd-Pass)' = 3/3 ] && cmp -s '$T/body' '$T/raw.png'"
req GET "/v1/jobs/$id" >/dev/null
check prog_json_raw_url "$(cat "$T/body")" python3 -c '
import json, sys
j = json.load(open(sys.argv[1])); p = j["passes"]
ok = j["denoise"] is True and p["raw_url"].endswith("/image.png?pass=3&denoise=0")
ok = ok and p["noise"] > 0
sys.exit(0 if ok else 1)' "$T/body"
# with format=exr and AOV channels: each pass's EXR denoised, its AOVs beside
"$RENDER" "$T/p2.json" -o "$T/pd2.exr" --denoise --aov albedo,depth --threads 2 -q
xid=$(post_job "progressive=1&denoise=1&format=exr&aov=albedo,depth" "$T/c.json")
wait_until 60 job_ended "$xid"
code=$(req GET "/v1/jobs/$xid/image.exr?pass=2")
check prog_exr_aov_pass_equals_cli "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/pd2.exr'"
code=$(req GET "/v1/jobs/$xid/image.png?pass=2&denoise=0")
check prog_exr_aov_raw_png "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/pr2.png'"
# the noise estimate is the raw passes': the same as a raw job's
rid=$(post_job "progressive=1" "$T/c.json")
curl -s -N -m 60 "$URL/v1/jobs/$rid/events" >"$T/sse-raw.txt"
check prog_raw_job_events_no_raw_url "$(head -c 300 "$T/sse-raw.txt")" \
    bash -c "grep -q 'event: pass' '$T/sse-raw.txt' && ! grep -q raw_url '$T/sse-raw.txt'"
wait_until 60 job_ended "$rid"
rn=$(jfield "$T/body" noise)
req GET "/v1/jobs/$id" >/dev/null
check prog_noise_of_raw "denoised $(jfield "$T/body" noise) raw $rn" \
    bash -c "[ -n '$rn' ] && [ '$(jfield "$T/body" noise)' = '$rn' ]"
code=$(req GET "/v1/jobs/$rid/image.png?pass=2&denoise=0")
check prog_raw_job_pass_raw "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/pr2.png'"

# ---- a frame-range job: each frame denoised ------------------------------------------
cp "$RAYD_ROOT/tests/integration/lib/anim.json" "$T/anim.json" # frames 2-9, 48x32
"$RENDER" "$T/anim.json" --frame 4 --denoise -o "$T/f4.png" -q
"$RENDER" "$T/anim.json" --frame 5 --denoise -o "$T/f5.exr" -q
id=$(post_job "frames=4-5&denoise=1&format=exr" "$T/anim.json")
check frames_202 "$(cat "$T/post.json")" grep -q '"frames"' "$T/post.json"
wait_until 60 job_ended "$id"
code=$(req GET "/v1/jobs/$id/frames/4.png")
check frame_4_denoised_equals_cli "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/f4.png'"
code=$(req GET "/v1/jobs/$id/frames/5.exr")
check frame_5_exr_denoised_equals_cli "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/f5.exr'"

# ---- bad values: 400 naming the parameter ----------------------------------------------
param_err() { # without python, whose start is slow on a loaded machine
    grep -q '^{"error":{"status":400,"code":"bad_parameter","message":"[^"]*'"$1" "$T/body" &&
        grep -q '"parameter":"'"$1"'"}}$' "$T/body"
}
for q in 'denoise=2' 'denoise=' 'denoise=yes' 'denoise=1&denoise=0' 'progressive=1&denoise=true'; do
    code=$(post_json "/v1/jobs?$q" "$T/c.json")
    check "bad_job_${q//[^a-z0-9]/_}" "status $code $(cat "$T/body")" param_err denoise
done
for q in 'aov=zdepth' 'aov=' 'aov=albedo,normal' 'aov=depth&aov=depth' 'progressive=1&aov=all'; do
    code=$(post_json "/v1/jobs?$q" "$T/c.json")
    check "bad_job_${q//[^a-z0-9]/_}" "status $code $(cat "$T/body")" param_err aov
done
code=$(req GET "/v1/jobs/$rid/image.png?denoise=2")
check bad_image_denoise_value "status $code $(cat "$T/body")" param_err denoise
code=$(req GET "/v1/jobs/$rid/image.png?denoise=0&denoise=0")
check bad_image_denoise_twice "status $code $(cat "$T/body")" param_err denoise
code=$(req GET "/v1/jobs/$rid/image.exr?denoise=0")
check bad_exr_takes_no_denoise "status $code $(cat "$T/body")" param_err denoise

# ---- --data-dir: a queued job renders denoised (and its AOV) after kill -9 ----------------
stop_rayd
D=$T/data
start_rayd --threads 1 --test-gate 0 --data-dir "$D"
dn=$(post_job "denoise=1" "$T/c.json")
av=$(post_job "aov=depth" "$T/c.json")
fr=$(post_job "frames=4-4&denoise=1" "$T/anim.json")
wait_until 60 job_state_is "$av" queued
pq=$(post_job "progressive=1&denoise=1" "$T/p4.json")
code=$(req GET "/v1/jobs/$pq/image.png?denoise=0")
check raw_before_first_pass_202 "status $code $(head -c 200 "$T/body")" \
    bash -c "[ $code = 202 ] && grep -q '\"state\":\"queued\"' '$T/body'"
kill -KILL "$RAYD_PID" 2>/dev/null
wait "$RAYD_PID" 2>/dev/null
RAYD_PID=
start_rayd --threads 2 --test-gate open --data-dir "$D"
wait_until 60 job_ended "$dn"
code=$(req GET "/v1/jobs/$dn/image.png")
check restart_denoised "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/d.png'"
wait_until 60 job_ended "$av"
code=$(req GET "/v1/jobs/$av/image.png")
check restart_aov "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/depth.png'"
wait_until 60 job_is "$fr" state succeeded
code=$(req GET "/v1/jobs/$fr/frames/4.png")
check restart_frame_denoised "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/f4.png'"

# ---- the memory budget counts the denoiser's apron and buffers -----------------------
stop_rayd
start_rayd --threads 2 --max-memory 32M
scene "$T/big.json" 512 512 1 spheres
code=$(post_json "/v1/render" "$T/big.json")
check budget_raw_fits "status $code" [ "$code" = 200 ]
code=$(post_json "/v1/render?denoise=1" "$T/big.json")
check budget_denoised_refused "status $code $(head -c 300 "$T/body")" \
    bash -c "[ $code = 413 ] || [ $code = 503 ]"
code=$(post_json "/v1/jobs?denoise=1&progressive=1" "$T/big.json")
check budget_denoised_job_refused "status $code $(head -c 300 "$T/body")" \
    bash -c "[ $code = 413 ] || [ $code = 503 ]"
# room for one denoised 512x512 render (two workers' apron'd tiles, about 86 MB) but not two:
# the second waits for room, 503 memory_full, while the first is held at the gate
stop_rayd
start_rayd --threads 2 --max-memory 128M --test-gate 0
scene "$T/big2.json" 512 512 1 spheres 2
code=$(post_json "/v1/jobs?denoise=1" "$T/big.json")
check budget_one_denoised_job "status $code" [ "$code" = 202 ]
bj=$(jfield "$T/body" id)
code=$(post_json "/v1/render?denoise=1" "$T/big2.json")
check budget_second_denoised_503 "status $code $(head -c 300 "$T/body")" \
    bash -c "[ $code = 503 ] && grep -q memory_full '$T/body' && [ '$(header Retry-After)' = 1 ]"
req DELETE "/v1/jobs/$bj" >/dev/null
gate open
scene "$T/small.json" 64 48 2 spheres
"$RENDER" "$T/small.json" -o "$T/small.png" --denoise -q
code=$(post_json "/v1/render?denoise=1" "$T/small.json")
check budget_small_denoised_fits "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/small.png'"
