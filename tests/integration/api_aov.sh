#!/usr/bin/env bash
# api_aov.sh -- POST /v1/render?aov=: with format=exr the AOVs as channels,
# with format=png one AOV as the image; both the bytes rayd-render writes
# for the same scene and region; cached apart from the plain image; the
# scene's render.aov as an EXR's default; bad values (a name given twice
# too) 400 naming aov.
source "$(dirname "$0")/lib/common.sh"

start_rayd --threads 2
scene "$T/path.json" 96 72 4 cornell
scene "$T/whitted.json" 160 120 2 whitted

for s in path whitted; do
    "$RENDER" "$T/$s.json" -o "$T/$s-ref.exr" --aov all --threads 1 -q
    "$RENDER" "$T/$s.json" -o "$T/$s-ref.png" --aov all --threads 1 -q
    code=$(post_json "/v1/render?format=exr&aov=all" "$T/$s.json")
    check "${s}_exr_aov_status" "status $code $(head -c 300 "$T/body")" [ "$code" = 200 ]
    check "${s}_exr_aov_equals_cli" "differs from rayd-render --aov all" cmp -s "$T/body" "$T/$s-ref.exr"
    exrheader "$T/body" >"$T/hdr.txt" 2>&1
    check "${s}_exr_aov_channels" "$(grep -c floating "$T/hdr.txt") channels" \
        bash -c "[ \$(grep -c ', 32-bit floating-point' '$T/hdr.txt') = 13 ] && grep -q '^    albedo.R,' '$T/hdr.txt' && grep -q '^    N.Z,' '$T/hdr.txt' && grep -q '^    objectId,' '$T/hdr.txt'"
    for n in albedo normal depth alpha object material; do
        code=$(post_json "/v1/render?aov=$n" "$T/$s.json")
        check "${s}_png_aov_$n" "status $code, or differs from rayd-render's $s-ref.$n.png" \
            bash -c "[ $code = 200 ] && [ '$(header Content-Type)' = image/png ] && cmp -s '$T/body' '$T/$s-ref.$n.png'"
    done
    # the plain image is still the plain image, after the AOVs were cached
    "$RENDER" "$T/$s.json" -o "$T/$s-plain.png" --threads 1 -q
    code=$(post_json "/v1/render" "$T/$s.json")
    check "${s}_png_after_aov" "status $code or not the plain PNG" \
        bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/$s-plain.png'"
done

# A region: the crop rayd-render --region writes, AOVs too.
"$RENDER" "$T/path.json" -o "$T/r.exr" --region 10,20,33,17 --aov depth,id -q
code=$(post_json "/v1/render?x=10&y=20&w=33&h=17&format=exr&aov=depth,id" "$T/path.json")
check region_exr_aov "status $code or bytes differ" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/r.exr'"

# The scene's render.aov is an EXR's default; a plain PNG is unchanged by it.
python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); s["render"]["aov"]=["normal"]; print(json.dumps(s))' "$T/whitted.json" >"$T/wn.json"
"$RENDER" "$T/wn.json" -o "$T/wn.exr" --threads 1 -q
code=$(post_json "/v1/render?format=exr" "$T/wn.json")
check scene_aov_default "status $code or bytes differ" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/wn.exr'"
exrheader "$T/body" >"$T/hdr.txt" 2>&1
check scene_aov_default_channels "$(grep -c floating "$T/hdr.txt") channels" \
    bash -c "[ \$(grep -c ', 32-bit floating-point' '$T/hdr.txt') = 6 ]"

# Bad values: 400 bad_parameter naming aov.
aov_err() { err_is "$T/body" 400 bad_parameter && [ "$(json "$T/body" 'j["error"]["parameter"]')" = aov ]; }
for q in 'aov=zdepth' 'aov=' 'aov=albedo,,depth' 'aov=albedo,normal' 'aov=id' 'format=png16&aov=depth' \
    'format=sums&samples=0-1&aov=depth' 'aov=depth&aov=albedo' 'format=exr&aov=Z' \
    'aov=normal,normal' 'format=exr&aov=depth,normal,depth' 'format=exr&aov=id,object'; do
    code=$(post_json "/v1/render?$q" "$T/whitted.json")
    check "bad_${q//[^a-z0-9]/_}" "status $code $(cat "$T/body")" aov_err
done
code=$(post_json "/v1/render?aov=zdepth" "$T/whitted.json")
check bad_aov_message "$(cat "$T/body")" grep -q "'zdepth' is no AOV" "$T/body"
# a name given twice is refused naming it, on a job too
code=$(post_json "/v1/render?aov=normal,normal" "$T/whitted.json")
check repeated_aov_message "$(cat "$T/body")" grep -q "aov: 'normal' is named more than once" "$T/body"
code=$(post_json "/v1/jobs?format=exr&aov=albedo,depth,albedo" "$T/whitted.json")
repeated_albedo() { aov_err && grep -q "'albedo' is named more than once" "$T/body"; }
check repeated_aov_job "status $code $(cat "$T/body")" repeated_albedo

long=$(python3 -c 'print(",".join(["albedo", "normal", "depth", "alpha", "object", "material"]))')
code=$(post_json "/v1/render?format=exr&aov=$long" "$T/whitted.json")
check long_list_ok "status $code: every AOV named once" [ "$code" = 200 ]
long=$(python3 -c 'print(",".join(["albedo"] * 400))')
code=$(post_json "/v1/render?format=exr&aov=$long" "$T/whitted.json")
check long_repeats_refused "status $code $(head -c 300 "$T/body")" aov_err
long=$(python3 -c 'print("x" * 3000)')
code=$(post_json "/v1/render?aov=$long" "$T/whitted.json")
check long_name_refused "status $code $(head -c 300 "$T/body")" aov_err
# the kept scene's image route takes no aov
code=$(post_json /v1/scenes "$T/whitted.json")
id=$(jfield "$T/body" id)
code=$(req GET "/v1/scenes/$id/image.png?aov=depth")
check scenes_image_refuses_aov "status $code $(cat "$T/body")" \
    bash -c "[ $code = 400 ] && grep -q \"unknown query parameter 'aov'\" '$T/body'"

stop_rayd TERM
