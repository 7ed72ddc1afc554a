#!/usr/bin/env bash
# asset_changes.sh -- a file a scene reads under --asset-dir is checked on
# every request that would answer from a cache (device, inode, size and
# modification time): a changed file gives the new image, equal to a fresh
# server's, whether its size changed or only its time (a same-size rewrite
# of the same inode); a deleted one gives the missing-file error; an
# unchanged one still hits both caches.  The image URL of such a scene
# (POST /v1/scenes, GET .../image.png) is revalidated, not immutable, its
# ETag follows the file, and a render in flight keeps the scene it loaded.
# Every time is set with touch -d, far in the past: nothing depends on the
# clock's resolution or on how long anything takes.
source "$(dirname "$0")/lib/common.sh"

A=$T/assets
mkdir -p "$A"
# tri OBJ-TRIANGLE-CORNER STAMP: writes tri.obj in place (the same inode)
# with its third corner at x = CORNER, and sets its time to STAMP
tri() {
    printf 'v 0 0 -3\nv 1 0 -3\nv %s 1 -3\nf 1 2 3\n' "$1" >"$A/tri.obj"
    touch -d "$2" "$A/tri.obj"
}
tri 0 '2001-01-01 00:00:01'
SCENE='{"render":{"width":32,"height":24},"objects":[{"type":"mesh","source":{"file":"tri.obj"},"material":{"emission":[1,0,0]}}]}'
printf '%s' "$SCENE" >"$T/scene.json"
ID=$(sha256sum "$T/scene.json" | cut -d' ' -f1)

# render OUT: POST /v1/render of the scene, a 200 PNG into OUT
render() {
    local code; code=$(post_json /v1/render "$T/scene.json")
    cp "$T/body" "$1" 2>/dev/null
    [ "$code" = 200 ] && is_png "$1"
}
# fresh OUT: the same render by a new server that never saw the scene
fresh() {
    start_node 1 --asset-dir "$A"
    curl -s -m 60 -o "$1" -H 'Content-Type: application/json' --data-binary @"$T/scene.json" \
        "${NODE_URL[1]}/v1/render"
    kill -TERM "${NODE_PID[1]}"
    wait "${NODE_PID[1]}" 2>/dev/null
    is_png "$1"
}
differ() { ! cmp -s "$1" "$2"; }
# render_same OUT REF: renders into OUT, the bytes of REF
render_same() { render "$1" && cmp -s "$1" "$2"; }
# fresh_same OUT REF: a fresh server's render into OUT, the bytes of REF
fresh_same() { fresh "$1" && cmp -s "$1" "$2"; }
# hits_grew BEFORE-SCENE BEFORE-RESULT: both caches' hit counters grew by one
hits_grew() {
    [ "$(metric rayd_cache_hits_total)" = $(($1 + 1)) ] &&
        [ "$(metric rayd_result_cache_hits_total)" = $(($2 + 1)) ]
}

start_rayd --asset-dir "$A" --test-gate open
check first_render "not a 200 PNG: $(head -c 300 "$T/body")" render "$T/v1.png"
h=$(metric rayd_cache_hits_total) x=$(metric rayd_result_cache_hits_total)
check unchanged_same_bytes "differs" render_same "$T/v1b.png" "$T/v1.png"
check unchanged_hits_caches "scene hits $(metric rayd_cache_hits_total) (was $h), result hits $(metric rayd_result_cache_hits_total) (was $x)" hits_grew "$h" "$x"

# --- the content changes (another size) -----------------------------------------
tri 0.75 '2001-01-01 00:00:02'
check changed_renders "not a 200 PNG" render "$T/v2.png"
check changed_differs "the old image came back" differ "$T/v1.png" "$T/v2.png"
check changed_equals_fresh "differs from a fresh server's" fresh_same "$T/v2_fresh.png" "$T/v2.png"
h=$(metric rayd_cache_hits_total) x=$(metric rayd_result_cache_hits_total)
render "$T/v2b.png"
check changed_then_hits_caches "scene hits $(metric rayd_cache_hits_total) (was $h), result hits $(metric rayd_result_cache_hits_total) (was $x)" hits_grew "$h" "$x"
check changed_then_same_bytes "differs" cmp -s "$T/v2.png" "$T/v2b.png"

# --- a same-size rewrite of the same inode: only the time tells ---------------
ino=$(stat -c %i:%s "$A/tri.obj")
tri 0.25 '2001-01-01 00:00:03'
check same_size_rewrite_setup "inode:size $ino -> $(stat -c %i:%s "$A/tri.obj")" \
    [ "$(stat -c %i:%s "$A/tri.obj")" = "$ino" ]
check same_size_renders "not a 200 PNG" render "$T/v3.png"
check same_size_differs "the old image came back" differ "$T/v2.png" "$T/v3.png"
check same_size_equals_fresh "differs from a fresh server's" fresh_same "$T/v3_fresh.png" "$T/v3.png"

# --- the image URL: revalidated, its ETag follows the file --------------------
code=$(post_json /v1/scenes "$T/scene.json")
check scenes_id_is_sha256 "HTTP $code: $(cat "$T/body")" \
    bash -c "[ $code = 201 ] && grep -qF '\"id\":\"$ID\"' '$T/body'"
req GET "/v1/scenes/$ID/image.png" >/dev/null
cp "$T/body" "$T/get3.png"
etag3=$(header ETag)
check get_equals_render "differs" cmp -s "$T/get3.png" "$T/v3.png"
check get_revalidated "Cache-Control: $(header Cache-Control)" [ "$(header Cache-Control)" = "public, no-cache" ]
code=$(req GET "/v1/scenes/$ID/image.png" -H "If-None-Match: $etag3")
check get_unchanged_304 "HTTP $code" [ "$code" = 304 ]
tri 0.5 '2001-01-01 00:00:04'
code=$(req GET "/v1/scenes/$ID/image.png" -H "If-None-Match: $etag3")
check get_changed_unknown "HTTP $code: $(head -c 300 "$T/body")" err_is "$T/body" 404 scene_unknown
post_json /v1/scenes "$T/scene.json" >/dev/null
code=$(req GET "/v1/scenes/$ID/image.png" -H "If-None-Match: $etag3")
cp "$T/body" "$T/get4.png"
check get_new_etag "HTTP $code, ETag $(header ETag) (was $etag3)" \
    bash -c "[ $code = 200 ] && [ -n '$(header ETag)' ] && [ '$(header ETag)' != '$etag3' ]"
check get_new_image "the old image came back, or none" \
    bash -c "[ -s '$T/get4.png' ] && ! cmp -s '$T/get3.png' '$T/get4.png'"

# a scene that reads no file keeps its immutable URL
printf '{"render":{"width":8,"height":8},"objects":[{"type":"sphere","center":[0,0,-3],"radius":1}]}' >"$T/plain.json"
post_json /v1/scenes "$T/plain.json" >/dev/null
req GET "/v1/scenes/$(sha256sum "$T/plain.json" | cut -d' ' -f1)/image.png" >/dev/null
check plain_still_immutable "Cache-Control: $(header Cache-Control)" \
    [ "$(header Cache-Control)" = "public, max-age=31536000, immutable" ]

# --- a render in flight keeps the scene it loaded ------------------------------
# The gate holds the render's tiles after its scene was compiled; the file
# changes before they are drawn.
tri 0.6 '2001-01-01 00:00:05'
gate 0
curl -s -m 60 -o "$T/inflight.png" -H 'Content-Type: application/json' \
    --data-binary @"$T/scene.json" "$URL/v1/render" &
cpid=$!
PIDS+=("$cpid")
held() { gate_read && [ "$(jfield "$T/gate.json" held)" -ge 1 ]; }
wait_until 60 held
tri 0.9 '2001-01-01 00:00:06'
gate open
wait "$cpid"
check after_inflight_new_file "not a 200 PNG" render "$T/v6.png"
check after_inflight_differs "the in-flight image came back" differ "$T/inflight.png" "$T/v6.png"
tri 0.6 '2001-01-01 00:00:05'
check inflight_keeps_scene "differs from a fresh render of the file it read" \
    fresh_same "$T/v5_fresh.png" "$T/inflight.png"

# --- deleted: the missing-file error, not the cached image ---------------------
rm "$A/tri.obj"
code=$(post_json /v1/render "$T/scene.json")
missing() { err_is "$T/body" 422 invalid_scene /objects/0/source/file && grep -q 'cannot open' "$T/body"; }
check deleted_missing_file "HTTP $code: $(head -c 300 "$T/body" | tr -cd '[:print:]')" missing
code=$(req GET "/v1/scenes/$ID/image.png")
check deleted_get_unknown "HTTP $code" [ "$code" = 404 ]

stop_rayd TERM
check stopped "rc $RAYD_RC" [ "$RAYD_RC" = 0 ]
exit $((NFAIL > 0))
