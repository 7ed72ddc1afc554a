#!/usr/bin/env bash
# limits_estimate.sh -- an estimate that cannot be gamed (issue 39, must-have
# 2; docs/api.md "Cost, budgets and fair shares", docs/operations.md "How a
# render is priced"):
#   - a scene's price in seconds is measured on its own tiles: after another
#     client's heavy render, a known scene's price is unchanged and a new
#     scene's (the node's rate: a median over clients) changes by less than
#     a small factor.  Before, one tile of a heavy 1-pixel scene moved the
#     single node-wide average some 500 times;
#   - a render the result cache holds is answered 200 from it even when its
#     price is over --max-render-seconds; an uncached region of the same
#     scene is refused 413;
#   - a tree of glass is priced by its depth: 16 x 16 pixels of glass
#     spheres at max_depth 20 (60 million rays) is refused at admission by
#     --max-work, where it was priced at 1,536 rays and admitted;
#   - the denoiser is priced: its apron and its filter, once a pass.  An
#     empty 1024 x 1024 scene denoised (0.5 KB of request, 2.2 s of CPU)
#     was priced as the 1M rays of its pixels, and a progressive job
#     denoised at every one of its passes as one filter.
# No check depends on the machine's speed beyond generous factors: the rates
# compared are each a median or a scene's own, and the refusals compare
# prices that differ by hundreds of times.
source "$(dirname "$0")/lib/common.sh"

# glass FILE SIDE DEPTH: a 7 x 7 x 3 grid of touching glass spheres filling
# the view, SIDE x SIDE pixels, max_depth DEPTH
glass() {
    python3 - "$@" <<'PY'
import json, sys
out, side, depth = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
objs = [{"type": "sphere", "center": [i, j, -k], "radius": 0.55, "material": "glass"}
        for i in range(-3, 4) for j in range(-3, 4) for k in range(3)]
json.dump({"camera": {"position": [0, 0, 4], "look_at": [0, 0, 0], "fov_x": 40},
           "render": {"width": side, "height": side, "samples": 1, "max_depth": depth},
           "materials": {"glass": {"color": [1, 1, 1], "diffuse": 0, "transparency": 0.9, "ior": 1.5}},
           "lights": [{"type": "point", "position": [3, 5, 8], "intensity": 1}],
           "objects": objs}, open(out, "w"))
PY
}
# lone_glass FILE SIDE DEPTH: one small glass ball in a corner of a wide sky:
# priced for the whole tree at every pixel, cheap to render
lone_glass() {
    python3 - "$@" <<'PY'
import json, sys
out, side, depth = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
json.dump({"camera": {"position": [0, 0, 10], "look_at": [0, 0, 0], "fov_x": 60},
           "render": {"width": side, "height": side, "samples": 1, "max_depth": depth},
           "materials": {"glass": {"color": [1, 1, 1], "diffuse": 0, "transparency": 0.9, "ior": 1.5}},
           "lights": [{"type": "point", "position": [3, 5, 8], "intensity": 1}],
           "objects": [{"type": "sphere", "center": [4, 4, 0], "radius": 0.3, "material": "glass"}]},
          open(out, "w"))
PY
}
secs() { header X-Rayd-Estimated-Seconds; }
# within A B FACTOR: A and B (> 0) differ by at most FACTOR times
within() { python3 -c 'import sys; a, b, f = map(float, sys.argv[1:]); sys.exit(not (a > 0 and b > 0 and max(a / b, b / a) <= f))' "$1" "$2" "$3"; }
over() { python3 -c 'import sys; sys.exit(not float(sys.argv[1]) > float(sys.argv[2]))' "$1" "$2" 2>/dev/null; }

glass "$T/heavy.json" 1 14 # one pixel of a deep glass tree: thousands of rays
for k in 1 2 3; do scene "$T/c$k.json" 160 120 16 spheres "$k"; done
scene "$T/new1.json" 160 120 16 spheres 11
scene "$T/new2.json" 160 120 16 spheres 12

# --- one client's heavy scene does not move the others' prices ----------------------------
start_rayd --threads 1 --client-header X-Client
for k in 1 2 3; do post_json /v1/render "$T/c$k.json" -H "X-Client: c$k" >/dev/null; done
post_json /v1/render "$T/c1.json" -H 'X-Client: c1' >/dev/null # cached: the price only
known1=$(secs)
code=$(post_json /v1/render "$T/new1.json" -H 'X-Client: c4')
new1=$(secs)
check isolation_setup "status $code, seconds '$known1' '$new1'" \
    bash -c "[ $code = 200 ] && [ -n '$known1' ] && [ -n '$new1' ]"
code=$(post_json /v1/render "$T/heavy.json" -H 'X-Client: evil')
check isolation_heavy_rendered "status $code: $(head -c 200 "$T/body" | tr -d "\\0")" [ "$code" = 200 ]
post_json /v1/render "$T/c1.json" -H 'X-Client: c1' >/dev/null
known2=$(secs)
post_json /v1/render "$T/new2.json" -H 'X-Client: c4' >/dev/null
new2=$(secs)
check isolation_known_scene "a known scene's price $known1 s, after another's heavy render $known2 s" \
    within "$known1" "$known2" 1.5
echo "# prices: known $known1 -> $known2, new $new1 -> $new2"
check isolation_new_scene "a new scene's price $new1 s, after another's heavy render $new2 s" \
    within "$new1" "$new2" 4
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- a cached render is never refused for its cost --------------------------------------
# S is priced near 3.3 s at the starting rate (1e7 estimated rays a second)
# and renders in milliseconds.  Then 300 one-pixel scenes from two other
# clients, each costing a tile's overhead for one estimated ray, make the
# node's rate slow and push S's own rate out of the table, and a heavy
# pixel from S's own client poisons the old single average: S is priced
# over 4 x --max-render-seconds from then on.
lone_glass "$T/s.json" 256 7
start_rayd --threads 1 --client-header X-Client --max-render-seconds 1
code=$(post_json /v1/render "$T/s.json" -H 'X-Client: s')
cp "$T/body" "$T/s.png"
check cached_first_render "status $code, $(secs) s: $(head -c 200 "$T/body" | tr -d "\\0")" \
    bash -c "[ $code = 200 ] && [ \"\$(head -c 4 '$T/s.png' | tail -c 3)\" = PNG ]"
# one curl for all 300 (a process each would take longer than the renders)
: >"$T/flood.cfg"
for i in $(seq 1 300); do
    printf '{"render": {"width": 1, "height": 1, "samples": 1, "max_depth": 0}, "objects":
 [{"type": "sphere", "center": [0, 0, -3], "radius": 1}]}%*s\n' "$i" "" >"$T/one$i.json"
    printf 'url = "%s/v1/render"\ndata-binary = "@%s"\nheader = "Content-Type: application/json"
header = "X-Client: %s"\noutput = "/dev/null"\nwrite-out = "%%{http_code}\\n"\n%s' \
        "$URL" "$T/one$i.json" "$([ $((i % 2)) = 0 ] && echo q || echo p)" \
        "$([ "$i" -lt 300 ] && echo next)" >>"$T/flood.cfg"
    echo >>"$T/flood.cfg"
done
flood=$(curl -s -m 300 -K "$T/flood.cfg" | grep -c '^200$')
check cached_flood_rendered "$flood of 300" [ "$flood" = 300 ]
post_json /v1/render "$T/heavy.json" -H 'X-Client: s' >/dev/null
code=$(post_json /v1/render "$T/s.json" -H 'X-Client: s')
check cached_answered_200 "status $code, priced $(secs) s: $(head -c 300 "$T/body" | tr -d "\\0")" \
    bash -c "[ $code = 200 ] && cmp -s '$T/body' '$T/s.png'"
echo "# the cached render priced $(secs) s"
check cached_priced_over "the cached render is priced $(secs) s, want over 4" over "$(secs)" 4
code=$(post_json "/v1/render?x=0&y=0&w=255&h=256" "$T/s.json" -H 'X-Client: s')
check cached_uncached_region_413 "status $code: $(head -c 300 "$T/body" | tr -d "\\0")" \
    err_is "$T/body" 413 over_budget
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- a deep glass tree is refused at admission ----------------------------------------
glass "$T/deep.json" 16 20
glass "$T/shallow.json" 16 8
start_rayd --threads 1 --max-work 100000000
code=$(post_json /v1/jobs "$T/deep.json")
check glass_depth20_413 "status $code, priced $(header X-Rayd-Estimated-Rays): $(head -c 300 "$T/body" | tr -d "\\0")" \
    err_is "$T/body" 413 over_budget
check glass_depth20_message "$(head -c 300 "$T/body" | tr -d "\\0")" grep -q -- '--max-work' "$T/body"
[ "$code" = 202 ] && req DELETE "/v1/jobs/$(jfield "$T/body" id)" >/dev/null
code=$(post_json /v1/render "$T/shallow.json")
check glass_depth8_runs "status $code, priced $(header X-Rayd-Estimated-Rays)" \
    bash -c "[ $code = 200 ] && [ \"\$(head -c 4 '$T/body' | tail -c 3)\" = PNG ]"
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- the denoiser is priced: its apron, and its filter once a pass ------------------------------
echo '{"render": {"width": 1024, "height": 1024, "samples": 1}, "objects": []}' >"$T/big.json"
echo '{"render": {"width": 256, "height": 256, "samples": 8}, "objects": []}' >"$T/small.json"
start_rayd --threads 1 --max-work 5000000
# job_ok NAME QUERY FILE: a job admitted (then deleted); job_413 NAME PATH FILE: refused
job_ok() {
    code=$(post_json "/v1/jobs?$2" "$3")
    check "$1" "status $code, priced $(header X-Rayd-Estimated-Rays): $(head -c 200 "$T/body")" [ "$code" = 202 ]
    [ "$code" = 202 ] && req DELETE "/v1/jobs/$(jfield "$T/body" id)" >/dev/null
}
job_413() {
    code=$(post_json "$2" "$3")
    check "$1" "status $code, priced $(header X-Rayd-Estimated-Rays): $(head -c 300 "$T/body")" \
        err_is "$T/body" 413 over_budget
    [ "$code" = 202 ] && req DELETE "/v1/jobs/$(jfield "$T/body" id)" >/dev/null
}
job_ok denoise_off_admitted "denoise=0" "$T/big.json"          # 1M rays
job_413 denoise_on_refused "/v1/render?denoise=1" "$T/big.json" # its filter and apron: 43M
job_ok denoise_small_admitted "denoise=1" "$T/small.json"      # 256 x 256 x (8 + 20): 1.8M
job_ok progressive_admitted "progressive=1&pass_step=1" "$T/small.json"
job_413 progressive_denoise_refused "/v1/jobs?progressive=1&pass_step=1&denoise=1" "$T/small.json" # 8 filters: 11M
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- the EXR's encode is priced: 0.5 rays a channel a pixel ----------------------------------
# An empty 1024 x 1024 scene is 1M rays as a PNG; as an EXR with every AOV (13 channels) its
# encode adds 6.8M, over a --max-work of 5M.  Before, an 84-byte scene at 4096 x 4096 with
# ?aov=all was priced at its 16.7M rays and spent 8 s of its 13 s in the encode.
start_rayd --threads 1 --max-work 5000000
job_ok exr_rgb_admitted "format=exr" "$T/big.json" # 1M + 1.5M
job_413 exr_aov_all_refused "/v1/render?format=exr&aov=all" "$T/big.json"
job_413 job_exr_aov_refused "/v1/jobs?format=exr&aov=all" "$T/big.json"
job_ok png_aov_admitted "aov=normal" "$T/big.json" # a PNG of one AOV: no EXR to write
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- sums are priced: 2 rays a pixel more -------------------------------------------------------
# Their 24 bytes a pixel cost more than the rays of an empty scene: the 1024 x 1024 one-sample
# sums are 1M + 2M rays, over a --max-work of 2.5M.  Before, a 74-byte request of a 4096 x 4096
# scene's sums was priced at its 16.7M rays, passed a --max-work of 16.7M and took 4 s of CPU
# where its PNG took 0.45 s.
start_rayd --threads 1 --max-work 2500000
code=$(post_json "/v1/render" "$T/big.json")
check sums_png_admitted "status $code, priced $(header X-Rayd-Estimated-Rays)" [ "$code" = 200 ]
code=$(post_json "/v1/render?format=sums&samples=0-1" "$T/big.json")
check sums_refused "status $code: $(head -c 200 "$T/body")" \
    err_is "$T/body" 413 over_budget
check sums_priced "$(head -c 200 "$T/body")" grep -q "estimated cost is 3.15e+06 rays" "$T/body"
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- a frame-range job's frames are priced with their parse -------------------------------------
# Each frame parses the scene again: its text, its objects' BVH, and its gltf objects' bake,
# and, when the glTF plays an animation, the BVHs of its meshes (never shared between
# frames).  A few KB of glTF drawing one mesh of 1000 triangles 200 times (200k triangles)
# under a moving root is 1.2M rays' worth of parse a frame, over a --max-work of 1M; the
# same glTF standing still is 0.2M.  Before, a 15.8 KB scene of 5M such triangles was
# priced at 1,806 rays a frame of 1 pixel and took 2.5-3 s of CPU a frame for 1000 frames.
# A mesh object's glTF source is decoded and built each frame too (only OBJ and PLY are
# shared): 6 rays a triangle, the same 1.2M.  Before, it was priced as its text: a 228 KB
# scene of 5M triangles, 1000 frames of 8 x 8 pixels, was 14.5M rays for the whole job
# under --max-work 1e7 and took 2.3 s of CPU a frame (38 minutes).
# gltf_anim FILE MOVING [KIND]: a 16 x 16 scene of that glTF, 10 frames, its root moving or
# not, as a gltf object (KIND mesh: a mesh object's source)
gltf_anim() {
    python3 - "$@" <<'PY'
import base64, json, random, struct, sys
out, moving = sys.argv[1], sys.argv[2] == "1"
kind = sys.argv[3] if len(sys.argv) > 3 else "gltf"
random.seed(1)
pos = b"".join(struct.pack("<3f", random.random(), random.random(), random.random())
               for _ in range(256))
idx = bytes(random.randrange(256) for _ in range(3000))
keys = struct.pack("<2f", 0.0, 1.0) + struct.pack("<6f", 0, 0, 0, 5, 0, 0)
buf = pos + idx + keys
views = [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
         {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)},
         {"buffer": 0, "byteOffset": len(pos) + len(idx), "byteLength": 8},
         {"buffer": 0, "byteOffset": len(pos) + len(idx) + 8, "byteLength": 24}]
acc = [{"bufferView": 0, "componentType": 5126, "count": 256, "type": "VEC3",
        "min": [0, 0, 0], "max": [1, 1, 1]},
       {"bufferView": 1, "componentType": 5121, "count": 3000, "type": "SCALAR"},
       {"bufferView": 2, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]},
       {"bufferView": 3, "componentType": 5126, "count": 2, "type": "VEC3"}]
g = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
     "buffers": [{"byteLength": len(buf),
                  "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
     "bufferViews": views, "accessors": acc,
     "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}] * 10}],
     "nodes": [{"children": list(range(1, 21))}] +
              [{"mesh": 0, "translation": [2 * i, 0, 0]} for i in range(20)]}
if moving:
    g["animations"] = [{"channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}],
                        "samplers": [{"input": 2, "output": 3}]}]
json.dump({"animation": {"end": 9}, "render": {"width": 16, "height": 16},
           "camera": {"position": [20, 0, 60], "look_at": [20, 0, 0]},
           "lights": [{"type": "point", "position": [20, 10, 30]}],
           "objects": [{"type": kind, "source": {"text": json.dumps(g), "format": "gltf"}}]},
          open(out, "w"))
PY
}
gltf_anim "$T/moving.json" 1
gltf_anim "$T/standing.json" 0
gltf_anim "$T/mesh_source.json" 0 mesh
start_rayd --threads 1 --max-work 1000000
code=$(post_json "/v1/jobs?frames=0-9" "$T/moving.json")
check frame_parse_refused "status $code: $(head -c 300 "$T/body")" eval \
    'err_is "$T/body" 413 over_budget && grep -q "rays (--max-work) a frame; of it the frame.s parse of the scene is 1.2" "$T/body"'
code=$(post_json "/v1/render" "$T/moving.json")
check frame_parse_not_in_render "status $code: $(head -c 300 "$T/body" | tr -d "\\0")" [ "$code" = 200 ]
code=$(post_json "/v1/jobs?frames=0-9" "$T/mesh_source.json")
check frame_parse_mesh_source_refused "status $code: $(head -c 300 "$T/body")" eval \
    'err_is "$T/body" 413 over_budget && grep -q "rays (--max-work) a frame; of it the frame.s parse of the scene is 1.2" "$T/body"'
code=$(post_json "/v1/jobs?frames=0-9" "$T/standing.json")
rays=$(header X-Rayd-Estimated-Rays)
check frame_parse_standing_priced "status $code, priced $rays: $(head -c 300 "$T/body")" \
    eval '[ "$code" = 202 ] && [ "$rays" -gt 2000000 ] && [ "$rays" -lt 4000000 ]'
# A frame's price over the same render's: its parse (its text at 16 bytes a ray, its one
# object at 10, its one owner of keyframes at 100) and its part of the video (1 ray a
# pixel).  Before, the two were equal.
cat >"$T/tiny_anim.json" <<'JSON'
{"animation": {"end": 3}, "render": {"width": 64, "height": 64},
 "camera": {"look_at": [0, 0, 0], "keyframes": [{"frame": 0, "position": [0, 0, 4]},
                                                {"frame": 3, "position": [1, 0, 4]}]},
 "lights": [{"type": "point", "position": [0, 5, 5]}],
 "objects": [{"type": "sphere"}]}
JSON
post_json /v1/render "$T/tiny_anim.json" >/dev/null
render=$(header X-Rayd-Estimated-Rays)
post_json "/v1/jobs?frames=0-0" "$T/tiny_anim.json" >/dev/null
frame=$(header X-Rayd-Estimated-Rays)
want=$(python3 -c "print(round($render + 64 * 64 + $(stat -c %s "$T/tiny_anim.json") / 16 + 10 + 100))")
check frame_priced_parse_and_video "render $render, frame $frame, want $want" \
    eval '[ $((frame - want)) -ge -1 ] && [ $((frame - want)) -le 1 ]'
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]
