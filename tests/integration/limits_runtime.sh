#!/usr/bin/env bash
# limits_runtime.sh -- limits enforced while a render runs, not only at the
# door: a DELETE, --max-work (rays actually cast), --max-render-seconds and
# the drain stop a render whose one pixel is very costly within a bounded
# time; SIGTERM ends the process within --drain-seconds plus a small bound
# and answers the synchronous client; a second signal ends it at once.
#
# A CSG tree's point tests count against --max-work as they go, beside the
# rays (an 8x8 render of 64 rays is stopped by the million tests they do),
# and so does the denoiser's filter (20 rays' worth a pixel).
#
# The hostile scenes are one pixel each, so a render is a single tile that
# the old per-row cancel check never looked inside:
#   - glass: a 4x4x4 grid of glass spheres at max_depth 32, 16 samples --
#     every hit casts a reflected and a refracted ray: some 1e9 rays, minutes;
#   - instances: 20,000 instances of a 20,000-sphere group all in one place,
#     the camera ray through every box and missing every sphere: one ray
#     meets 4e8 spheres, tens of seconds.
# The test gate (--test-gate 0) lets the tile start when the test says, so
# "running" is a state the test sees (the gate's started count), not a
# race.  The time bounds are generous (a busy machine, ASan): they only
# tell "stopped within milliseconds" from "ran to the end", which takes
# minutes for the glass pixel and tens of seconds for the instances.
source "$(dirname "$0")/lib/common.sh"

python3 - "$T" <<'PY'
import json, sys
t = sys.argv[1]
spheres = [{"type": "sphere", "center": [(i % 4) * 2.2 - 3.3, (i // 4 % 4) * 2.2 - 3.3,
                                         (i // 16) * 2.2 - 3.3], "radius": 1, "material": "glass"}
           for i in range(64)]
glass = {"render": {"width": 1, "height": 1, "samples": 16, "max_depth": 32},
         "camera": {"position": [0.3, 0.2, -12], "look_at": [1.0, 1.2, 0], "fov_x": 20},
         "materials": {"glass": {"transparency": 0.9, "reflectivity": 0.1, "ior": 1.5}},
         "lights": [{"type": "point", "position": [0, 20, -20]}], "objects": spheres}
json.dump(glass, open(t + "/glass.json", "w"), separators=(",", ":"))
glass["render"]["seed"] = 7  # another scene id: no task to join
json.dump(glass, open(t + "/glass2.json", "w"), separators=(",", ":"))
m = 20000
inst = {"render": {"width": 1, "height": 1, "max_depth": 0},
        "camera": {"position": [0.9, 0.9, -10], "look_at": [0.9, 0.9, 0]},
        "groups": {"g": [{"type": "sphere", "radius": 1}] * m},
        "objects": [{"type": "instance", "group": "g"}] * m}
json.dump(inst, open(t + "/inst.json", "w"), separators=(",", ":"))
PY
scene "$T/small.json" 8 8 1 spheres

# started N: the gate has let N tiles start (a worker is inside the pixel)
started() { gate_is started "$1"; }
# elapsed START: whole seconds since START (date +%s%N)
elapsed() { echo $((($(date +%s%N) - $1) / 1000000000)); }
# sync_render FILE NAME: POST /v1/render in the background; status in
# $T/NAME.code, body in $T/NAME.body, the seconds it took in $T/NAME.s
sync_render() {
    (
        s=$(date +%s%N)
        curl -s -m 120 -o "$T/$2.body" -w '%{http_code}' -X POST \
            -H 'Content-Type: application/json' --data-binary @"$1" "$URL/v1/render" >"$T/$2.code"
        elapsed "$s" >"$T/$2.s"
    ) &
    PIDS+=($!)
    SYNC_PID=$!
}
# limit_answer FILE FLAG: a 413 whose message names FLAG: stopped while it
# ran (too_large) or, should the estimate see the cost, refused at the door
# (over_budget)
limit_answer() {
    python3 - "$1" "$2" <<'PY' 2>/dev/null
import json, sys
e = json.load(open(sys.argv[1]))["error"]
sys.exit(0 if e["status"] == 413 and e["code"] in ("too_large", "over_budget")
         and sys.argv[2] in e["message"] else 1)
PY
}

# The estimate (core/scene/scene_cost.c) prices both scenes far past the
# default --max-render-seconds, so the servers that must admit them to stop
# them running set no seconds budget (0).

# --- a DELETE is seen inside the one costly pixel ---------------------------------
start_rayd --threads 1 --test-gate 0 --max-render-seconds 0
post_json /v1/jobs "$T/glass.json" >/dev/null
job=$(jfield "$T/body" id)
gate 1
wait_until 60 started 1
code=$(req DELETE "/v1/jobs/$job")
t0=$(date +%s%N)
gate open
code=$(post_json /v1/render "$T/small.json")
took=$(elapsed "$t0")
check delete_frees_worker "the 8x8 render behind the deleted job: $code after $took s" \
    bash -c "[ $code = 200 ] && [ $took -le 10 ]"
check delete_counted "rayd_canceled_total{reason=\"delete\"} $(metric 'rayd_canceled_total{reason="delete"}')" \
    metric_is 'rayd_canceled_total{reason="delete"}' 1
stop_rayd TERM
check delete_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]

# --- --max-work: the rays actually cast stop the render ------------------------------
# timed_render FILE: POST /v1/render of FILE; its status in $code, the seconds in $took
timed_render() {
    local t0
    t0=$(date +%s%N)
    code=$(post_json /v1/render "$1")
    took=$(elapsed "$t0")
}
start_rayd --threads 1 --max-work 100000
timed_render "$T/glass.json"
check max_work_stops_render "status $code after $took s: $(head -c 300 "$T/body")" \
    bash -c "[ $code = 413 ] && [ $took -le 20 ]"
check max_work_message "$(head -c 400 "$T/body")" limit_answer "$T/body" "100000 rays (--max-work)"
check max_work_advice "$(head -c 400 "$T/body")" \
    grep -q 'ask for fewer pixels, samples, bounces or light samples' "$T/body"
code=$(post_json /v1/render "$T/small.json")
check max_work_small_renders "status $code" [ "$code" = 200 ]
# a job: fails with the same message
post_json /v1/jobs "$T/glass2.json" >/dev/null
job=$(jfield "$T/body" id)
if [ "$(json "$T/body" 'j.get("error",{}).get("code","")')" = over_budget ]; then
    pass max_work_job_fails # refused at the door: nothing to stop
else
    wait_until 30 job_state_is "$job" failed
    check max_work_job_fails "$(head -c 400 "$T/body")" \
        bash -c "grep -q '\"state\":\"failed\"' '$T/body' && grep -q -- '--max-work' '$T/body'"
fi
stop_rayd TERM

# --- a progressive job that passes its ray budget keeps its latest pass -----------------
# The estimate refuses at the door what it prices over --max-work, so the
# test gate's work knob sets the run-time budget alone: 20,000 rays, about
# six samples of 32x32 spheres; the passes are 1, 2, 4, ... 64 samples.
start_rayd --threads 1 --max-render-seconds 0 --test-gate open
curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?work=20000" >/dev/null
scene "$T/prog.json" 32 32 64 spheres
code=$(post_json '/v1/jobs?progressive=1' "$T/prog.json")
job=$(jfield "$T/body" id)
wait_until 60 bash -c "curl -s -m 5 '$URL/v1/jobs/$job' | grep -q '\"state\":\"\(succeeded\|failed\)\"'"
req GET "/v1/jobs/$job" >/dev/null
cp "$T/body" "$T/prog.job"
done_passes=$(json "$T/prog.job" 'j["passes"]["done"]' 2>/dev/null)
check max_work_progressive_keeps_pass "$(head -c 500 "$T/prog.job")" \
    bash -c "grep -q '\"state\":\"succeeded\"' '$T/prog.job' && grep -q '\"stopped_by\":\"max_work\"' '$T/prog.job' && [ '${done_passes:-0}' -ge 1 ] && [ '${done_passes:-0}' -lt 7 ]"
code=$(req GET "/v1/jobs/$job/image.png")
check max_work_progressive_image "GET image.png: $code" bash -c "[ $code = 200 ] && head -c 4 '$T/body' | grep -q PNG"
curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?work=open" >/dev/null
stop_rayd TERM

# --- a CSG tree's point tests count, not only its rays ------------------------------
# The union of 1,024 concentric spheres (32 unions of 32) less a sphere that holds them all:
# no surface, but a ray through the middle crosses 2,050 and, at each, tests the tree's
# operands, some half a million point tests for one ray (15-45 ms).  (The tree was cut by a
# sphere far away, an intersection whose box is empty: the one-ray walks, all a CPU without
# AVX-512 has, skip it, and that 8x8 render took 0.3 ms, 200.)  The estimate prices a tree by its
# operands squared, so --max-work refuses it at the door; and the run-time budget (the
# test gate's work knob alone) counts the tests as they go, so an 8x8 render -- 64 rays,
# far under 20,000 -- is stopped by the work they do.
python3 - "$T" <<'PY'
import json, sys
n = [0]
def union(level):
    if level == 0:
        n[0] += 1
        return {"type": "sphere", "radius": round(1 + n[0] * 1e-4, 5)}
    return {"type": "csg", "op": "union", "operands": [union(level - 1) for _ in range(32)]}
cover = {"type": "sphere", "radius": 2}
s = {"render": {"width": 8, "height": 8},
     "camera": {"position": [0, 0, 10], "look_at": [0, 0, 0], "fov_x": 5},
     "lights": [{"type": "point", "position": [0, 5, 5]}],
     "objects": [{"type": "csg", "op": "difference", "operands": [union(2), cover]}]}
json.dump(s, open(sys.argv[1] + "/csg.json", "w"), separators=(",", ":"))
PY
start_rayd --threads 1 --max-work 1000000 --test-gate open
code=$(post_json /v1/render "$T/csg.json")
check csg_priced_at_door "status $code: $(head -c 300 "$T/body")" \
    bash -c "[ $code = 413 ] && grep -q over_budget '$T/body'"
stop_rayd TERM
start_rayd --threads 1 --max-render-seconds 0 --test-gate open
curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?work=20000" >/dev/null
timed_render "$T/csg.json"
check csg_work_stops_render "status $code after $took s: $(head -c 300 "$T/body")" \
    bash -c "[ $code = 413 ] && [ $took -le 20 ]"
check csg_work_message "$(head -c 400 "$T/body")" limit_answer "$T/body" "20000 rays (--max-work)"
curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?work=open" >/dev/null
code=$(post_json /v1/render "$T/small.json")
check csg_then_small_renders "status $code" [ "$code" = 200 ]
stop_rayd TERM

# --- the objects a ray visits count, not only the ray -----------------------------------
# 300 instances of a row of 300 tori down the camera's axis, seen from the end, orthographic:
# every ray threads all 90,000 holes and hits nothing (some 20 ms a ray), priced at about two
# rays a pixel.  Past 64 objects a ray, each visit counts as a ray: with a budget of 200,000
# (the test gate's work knob alone) the 16x16 render is stopped by its visits, at once.
python3 - "$T" <<'PY'
import json, sys
row = [{"type": "torus", "center": [0, 0, -10 * k], "axis": [0, 0, 1], "major_radius": 1,
        "minor_radius": 0.1} for k in range(300)]
s = {"render": {"width": 16, "height": 16},
     "camera": {"projection": "orthographic", "view_width": 1, "position": [0, 0, 10],
                "look_at": [0, 0, 0]},
     "lights": [{"type": "point", "position": [0, 5, 5]}], "groups": {"row": row},
     "objects": [{"type": "instance", "group": "row", "transform": {"translate": [0, 0, -3000 * j]}}
                 for j in range(300)]}
json.dump(s, open(sys.argv[1] + "/tori.json", "w"), separators=(",", ":"))
PY
start_rayd --threads 1 --max-render-seconds 60 --test-gate open
curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?work=200000" >/dev/null
timed_render "$T/tori.json"
check visits_stop_render "status $code after $took s: $(head -c 300 "$T/body")" \
    bash -c "[ $code = 413 ] && [ $took -le 20 ]"
check visits_message "$(head -c 400 "$T/body")" limit_answer "$T/body" "200000 rays (--max-work)"
curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?work=open" >/dev/null
code=$(post_json /v1/render "$T/small.json")
check visits_then_small_renders "status $code" [ "$code" = 200 ]
# the same row as objects of the scene itself (no instances): the 4x4 packets' walk counts too
python3 - "$T" <<'PY'
import json, sys
s = json.load(open(sys.argv[1] + "/tori.json"))
s["objects"] = [dict(o, center=[0, 0, -10 * k]) for k, o in enumerate(s.pop("groups")["row"] * 7)]
s["render"]["width"] = s["render"]["height"] = 32
json.dump(s, open(sys.argv[1] + "/tori_flat.json", "w"), separators=(",", ":"))
PY
curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?work=20000" >/dev/null
timed_render "$T/tori_flat.json"
check visits_packets_stop_render "status $code after $took s: $(head -c 300 "$T/body")" \
    bash -c "[ $code = 413 ] && grep -q -- '--max-work' '$T/body'"
# counted walk by walk: a scene and its mirror image (150 spheres over the top half of the
# view, or the bottom half) are stopped alike under any budget -- a running balance over the
# thread's rays charged the dense half only when its rays came first
stop_rayd TERM
# the one-ray walks (the packets' are counted a packet at a time, also whatever the order)
RAYD_WRAP="env RAYD_NO_AVX512=1" start_rayd --threads 1 --max-render-seconds 60 --test-gate open
same=
for w in 400 8000 40000; do
    for half in top:1 bottom:-1; do
        python3 - "$T/${half%%:*}.json" "${half#*:}" "$w" <<'PY'
import json, sys
json.dump({"render": {"width": 16, "height": 16, "seed": int(sys.argv[3])},
           "camera": {"projection": "orthographic", "view_width": 1, "position": [0, 0, 10],
                      "look_at": [0, 0, 0]},
           "lights": [{"type": "point", "position": [0, 0, 10]}],
           "objects": [{"type": "sphere", "center": [0, float(sys.argv[2]), 0], "radius": 0.75}
                       for _ in range(150)]}, open(sys.argv[1], "w"))
PY
    done
    curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?work=$w" >/dev/null
    same="$same $w:$(post_json /v1/render "$T/top.json")/$(post_json /v1/render "$T/bottom.json")"
done
check visits_order_free "budget:top/bottom$same" bash -c "! echo '$same' | grep -q -E '200/413|413/200'"
curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?work=open" >/dev/null
stop_rayd TERM

# --- the denoiser's work counts, not only the rays -----------------------------------
# A denoised 256x256 render of an empty scene is one tile (the denoiser's least) of 65,536
# camera rays, and its filter is RAYD_DENOISE_RAYS (20) rays' worth a pixel: 1.3 million.
# With the run-time budget at 200,000 (the test gate's work knob alone: the estimate, which
# prices the filter, would refuse it at the door) the rays fit and the filter does not, so
# the render is stopped at the filter's first level; with no budget it renders.
python3 - "$T" <<'PY'
import json, sys
s = {"render": {"width": 256, "height": 256, "samples": 1},
     "camera": {"position": [0, 0, 10], "look_at": [0, 0, 0]}, "objects": []}
json.dump(s, open(sys.argv[1] + "/empty.json", "w"))
PY
start_rayd --threads 1 --max-render-seconds 0 --test-gate open
curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?work=200000" >/dev/null
code=$(post_json '/v1/render?denoise=1' "$T/empty.json")
check denoise_work_stops_render "status $code" \
    limit_answer "$T/body" "200000 rays (--max-work)"
code=$(post_json '/v1/render?denoise=1&format=exr' "$T/empty.json")
check denoise_work_stops_exr "status $code" \
    limit_answer "$T/body" "200000 rays (--max-work)"
code=$(post_json '/v1/render' "$T/empty.json")
check undenoised_fits_budget "status $code" [ "$code" = 200 ]
# a job keeping its EXR beside its PNG filters once for both: 65,536 rays and 1.3 million
# of filter fit 2,000,000; filtering for each (2.7 million) would not
curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?work=2000000" >/dev/null
code=$(post_json '/v1/jobs?denoise=1&format=exr' "$T/empty.json")
job=$(jfield "$T/body" id)
wait_until 60 bash -c "curl -s -m 5 '$URL/v1/jobs/$job' | grep -q '\"state\":\"\(succeeded\|failed\)\"'"
req GET "/v1/jobs/$job" >/dev/null
check denoise_png_and_exr_filter_once "POST $code, job $(head -c 300 "$T/body")" \
    grep -q '"state":"succeeded"' "$T/body"
curl -s -m 30 -X POST -o "$T/gate.json" "$URL/v1/test/gate?work=open" >/dev/null
code=$(post_json '/v1/render?denoise=1' "$T/empty.json")
check denoise_renders_unbudgeted "status $code" [ "$code" = 200 ]
stop_rayd TERM

# --- --max-render-seconds: one ray through 20,000 instances is stopped -----------------
# A plain render priced past 4 x the limit is refused at the door; a
# progressive job is not (its passes end it), so it runs until the watcher
# stops it: inside its first pass, the one ray, so the job fails.
start_rayd --threads 1 --max-render-seconds 1
t0=$(date +%s%N)
code=$(post_json /v1/render "$T/inst.json")
check deadline_door "status $code: $(head -c 300 "$T/body")" \
    bash -c "[ $code = 413 ] && grep -q -- '--max-render-seconds' '$T/body'"
code=$(post_json '/v1/jobs?progressive=1' "$T/inst.json")
job=$(jfield "$T/body" id)
wait_until 30 job_state_is "$job" failed
took=$(elapsed "$t0")
check deadline_stops_ray "job $job after $took s: $(head -c 300 "$T/body")" \
    bash -c "grep -q '\"state\":\"failed\"' '$T/body' && [ $took -le 12 ]"
check deadline_message "$(head -c 400 "$T/body")" grep -q -- '--max-render-seconds' "$T/body"
stop_rayd TERM

# --- SIGTERM: the drain ends, the waiting client gets a JSON error -----------------------
start_rayd --threads 1 --drain-seconds 1 --test-gate 0 --max-render-seconds 0
sync_render "$T/glass.json" drain
wait_until 60 gate_is queued 1
gate 1
wait_until 60 started 1
t0=$(date +%s%N)
kill -TERM "$RAYD_PID"
wait_until 30 rayd_gone
took=$(elapsed "$t0")
stop_rayd TERM
check sigterm_exits "gone $took s after SIGTERM (--drain-seconds 1)" [ "$took" -le 12 ]
check sigterm_exit_0 "exit status $RAYD_RC" [ "$RAYD_RC" = 0 ]
wait "$SYNC_PID"
check sigterm_client_answered "status $(cat "$T/drain.code"): $(head -c 300 "$T/drain.body")" \
    err_is "$T/drain.body" 503 draining

# --- a second SIGTERM or SIGINT ends the process at once ------------------------------------
for sig in TERM INT; do
    start_rayd --threads 1 --drain-seconds 600 --test-gate 0 --max-render-seconds 0
    sync_render "$T/glass.json" second
    wait_until 60 gate_is queued 1
    gate 1
    wait_until 60 started 1
    kill -TERM "$RAYD_PID"
    wait_until 60 bash -c "[ \"\$(curl -s -o /dev/null -w '%{http_code}' '$URL/readyz')\" = 503 ]"
    t0=$(date +%s%N)
    kill -"$sig" "$RAYD_PID"
    wait_until 30 rayd_gone
    took=$(elapsed "$t0")
    stop_rayd TERM
    want=$((128 + $(kill -l "$sig")))
    check "second_sig${sig}_exits" "gone $took s after the second signal" [ "$took" -le 5 ]
    check "second_sig${sig}_status" "exit status $RAYD_RC, want $want" [ "$RAYD_RC" = "$want" ]
    check "second_sig${sig}_logged" "$(tail -n 3 "$T/rayd.err")" grep -q 'during the drain: exiting at once' "$T/rayd.err"
    wait "$SYNC_PID"
done

exit $((NFAIL > 0))
