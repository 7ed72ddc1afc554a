#!/usr/bin/env bash
# api_hdr.sh -- POST /v1/render in the HDR formats: ?format=exr|png16 and
# Accept: image/x-exr give the bytes rayd-render writes for the same scene
# and region (so tiles over HTTP stitch as on the command line); each
# format is cached apart (a PNG is never answered for an EXR, nor the
# reverse); bad formats are 400 naming the parameter.
source "$(dirname "$0")/lib/common.sh"

start_rayd --threads 2
scene "$T/path.json" 96 72 4 cornell
scene "$T/whitted.json" 160 120 2 whitted
HDR="$RAYD_BUILD/tests/tools/hdrcheck"

for s in path whitted; do
    "$RENDER" "$T/$s.json" -o "$T/$s-ref.exr" --threads 1
    "$RENDER" "$T/$s.json" -o "$T/$s-ref16.png" --format png16 --threads 1
    "$RENDER" "$T/$s.json" -o "$T/$s-ref.png" --threads 1
    code=$(post_json "/v1/render?format=exr" "$T/$s.json")
    cp "$T/body" "$T/$s.exr"
    check "${s}_exr_status" "status $code" [ "$code" = 200 ]
    check "${s}_exr_type" "$(header Content-Type)" [ "$(header Content-Type)" = image/x-exr ]
    check "${s}_exr_equals_cli" "differs from rayd-render -o x.exr" cmp -s "$T/$s.exr" "$T/$s-ref.exr"
    check "${s}_exr_pixels" "$("$HDR" "$T/$s-ref.png" "$T/$s.exr" 2>&1)" "$HDR" "$T/$s-ref.png" "$T/$s.exr"
    code=$(post_json "/v1/render?format=png16" "$T/$s.json")
    check "${s}_png16" "status $code or differs from rayd-render --format png16" \
        bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/$s-ref16.png'"
    code=$(post_json "/v1/render" "$T/$s.json" -H 'Accept: image/x-exr, image/png;q=0.5')
    check "${s}_accept_exr" "status $code, $(header Content-Type)" \
        bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/$s-ref.exr'"
    check "${s}_accept_vary" "Vary: $(header Vary)" [ "$(header Vary)" = Accept ]
    # only a parameter named q weighs, and after the other parameters too
    for acc in 'image/x-exr;note=aq=0, image/png;q=0.5' 'image/x-exr;v=1;q=0.9, image/png;Q=0.8'; do
        code=$(post_json "/v1/render" "$T/$s.json" -H "Accept: $acc")
        check "${s}_accept_exr_${acc//[^a-z0-9]/_}" "status $code, $(header Content-Type)" \
            bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/$s-ref.exr'"
    done
    # q=0 refuses a type (RFC 9110), a lower q than image/png's loses to it,
    # and a q that is no qvalue (above 1, four decimals) names nothing
    for acc in 'image/png, image/x-exr;q=0' 'image/x-exr; q=0' 'image/x-exr;q=0.4, image/png;q=0.5' \
        'image/x-exr;q=2' 'image/x-exr;q=0.5000'; do
        code=$(post_json "/v1/render" "$T/$s.json" -H "Accept: $acc")
        check "${s}_accept_png_${acc//[^a-z0-9]/_}" "status $code, $(header Content-Type)" \
            bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/$s-ref.png'"
    done
    # after the EXR is cached, the plain PNG is still the PNG
    code=$(post_json "/v1/render" "$T/$s.json")
    check "${s}_png_after_exr" "status $code or not the PNG" \
        bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/$s-ref.png'"
    code=$(post_json "/v1/render?format=png" "$T/$s.json")
    check "${s}_format_png" "status $code" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/$s-ref.png'"
done

# A region in EXR: the crop rayd-render --region writes.
"$RENDER" "$T/path.json" -o "$T/r.exr" --region 10,20,33,17
code=$(post_json "/v1/render?x=10&y=20&w=33&h=17&format=exr" "$T/path.json")
check region_exr_equals_cli "status $code or bytes differ" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/r.exr'"
exrheader "$T/body" >"$T/hdr.txt" 2>&1
check region_exr_exrheader "$(grep dataWindow "$T/hdr.txt")" grep -q 'dataWindow.*(0 0) - (32 16)' "$T/hdr.txt"

# The result cache answers the second EXR request, and still as EXR.
before=$(metric 'rayd_result_cache_hits_total')
code=$(post_json "/v1/render?format=exr" "$T/path.json")
after=$(metric 'rayd_result_cache_hits_total')
check exr_from_result_cache "status $code, type $(header Content-Type), hits $before -> $after" \
    bash -c "[ $code = 200 ] && [ '$(header Content-Type)' = image/x-exr ] && cmp -s '$T/body' '$T/path-ref.exr' && [ '${after:-0}' != '${before:-0}' ]"

# Bad formats: 400, the parameter named.
code=$(post_json "/v1/render?format=jpeg" "$T/path.json")
check bad_format "status $code $(cat "$T/body")" bash -c "[ $code = 400 ] && grep -q 'must be png, png16, exr or sums' '$T/body'"
# param_err: the body is the API's 400 bad_parameter naming parameter format
param_err() { err_is "$T/body" 400 bad_parameter && [ "$(json "$T/body" 'j["error"]["parameter"]')" = format ]; }
check bad_format_json "not the API error naming format: $(cat "$T/body")" param_err
code=$(post_json "/v1/render?format=exr&format=png" "$T/path.json")
check twice_format "status $code $(cat "$T/body")" param_err
# other routes still refuse format as unknown
code=$(post_json "/v1/scenes" "$T/path.json")
id=$(jfield "$T/body" id)
code=$(req GET "/v1/scenes/$id/image.png?format=exr")
check scenes_image_refuses_format "status $code $(cat "$T/body")" param_err

stop_rayd TERM
