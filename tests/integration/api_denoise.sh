#!/usr/bin/env bash
# api_denoise.sh -- POST /v1/render?denoise=1: the bytes rayd-render
# --denoise writes, for the frame and for a region (tiled by the server
# into tiles, each rendered with the filter's apron); EXR too; cached apart
# from the raw image; the scene's render.denoise as the default, which
# ?denoise=0 turns off; bad values 400 naming denoise.
source "$(dirname "$0")/lib/common.sh"

start_rayd --threads 2
scene "$T/c.json" 120 90 4 cornell

"$RENDER" "$T/c.json" -o "$T/d.png" --denoise --threads 1 -q
"$RENDER" "$T/c.json" -o "$T/raw.png" --threads 1 -q
code=$(post_json "/v1/render?denoise=1" "$T/c.json")
check frame_equals_cli "status $code or differs from rayd-render --denoise" \
    bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/d.png'"
code=$(post_json "/v1/render" "$T/c.json")
check raw_after_denoised "status $code or not the raw image" \
    bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/raw.png'"

"$RENDER" "$T/c.json" -o "$T/r.png" --denoise --region 50,20,70,50 --threads 2 -q
code=$(post_json "/v1/render?denoise=1&x=50&y=20&w=70&h=50" "$T/c.json")
check region_equals_cli "status $code or differs" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/r.png'"
check region_is_crop "the region is not the crop of the frame" "$RAYD_BUILD/tests/tools/pngcmp" "$T/d.png" "$T/body" 50 20

"$RENDER" "$T/c.json" -o "$T/d.exr" --denoise --threads 2 -q
code=$(post_json "/v1/render?denoise=1&format=exr" "$T/c.json")
check exr_equals_cli "status $code or differs" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/d.exr'"

python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); s["render"]["denoise"]=True; print(json.dumps(s))' "$T/c.json" >"$T/cd.json"
code=$(post_json "/v1/render" "$T/cd.json")
check scene_default "status $code or not denoised" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/d.png'"
code=$(post_json "/v1/render?denoise=0" "$T/cd.json")
check scene_off "status $code or not raw" bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/raw.png'"

dn_err() { err_is "$T/body" 400 bad_parameter && [ "$(json "$T/body" 'j["error"]["parameter"]')" = denoise ]; }
for q in 'denoise=2' 'denoise=' 'denoise=yes' 'denoise=1&denoise=1' 'format=sums&samples=0-1&denoise=1'; do
    code=$(post_json "/v1/render?$q" "$T/c.json")
    check "bad_${q//[^a-z0-9]/_}" "status $code $(cat "$T/body")" dn_err
done
