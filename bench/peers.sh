#!/usr/bin/env bash
# bench/peers.sh BUILD -- rayd side by side with Embree and POV-Ray, in one
# run on one machine, and rayd's ratios to them; `make bench-peers` runs it
# (after `make bench-deps` put libembree-dev and povray on the machine).
#
#   meshes   the ~1M-triangle genmesh mesh (mesh-8), the 5k one (mesh-4) and
#            the Stanford bunny when bench/bunny.sh could fetch it: raybench
#            vs embree_bench, the same 1920x1080 rays (primary and shadow,
#            one thread, one ray at a time and as packets of 4x4 pixels --
#            rayd's scene_intersect16 against Embree's rtcIntersect16; BVH
#            build on 2 threads each), median of RUNS runs
#            and, in CPU seconds, against Embree's robust mode too
#            (embree_bench --robust: its closest to rayd's watertight walks)
#   spheres  bench/scenes/spheres10.json by rayd-render --threads 1 (its
#            --stats wall time: the render, not the parse; a run is the
#            mean of FRAMES renders, about one POV-Ray trace long) vs
#            bench/peers/spheres10.pov by povray +WT1 -A (its reported
#            trace time, not parse or bounding), median of RUNS runs
#   whole    what a user waits for: the whole rayd-render process on 2
#            threads (start to PNG written) for spheres10 against POV-Ray's
#            trace on 2 threads, and for the 1.3M mesh (binary PLY, OBJ)
#            against Embree's load + medium build + 16-wide primary and
#            shadow rays, the load being the PLY read for the PLY and the
#            OBJ parsed by tinyobjloader for the OBJ (objparse.cc), as issue
#            16 words it; the OBJ also against the PLY load, stricter (see
#            the section below for how each side is timed)
#
# Every ratio is rayd's speed over the peer's (> 1: rayd is faster); the
# targets are issue 4's and the verdict is on the wall-clock ratio.  Beside
# it, the same one-thread comparisons timed in CPU seconds (raybench and
# embree_bench --cpu-time; POV-Ray's own CPU-seconds against raybench's
# one-thread image of spheres10.json): on a machine shared with other work
# those move less, so a verdict the two columns disagree on is noise.  Quote
# ratios from one run.
set -eu
cd "$(dirname "$0")/.."
BUILD=${1:-build}
RUNS=${RUNS:-3}
D=$BUILD/bench
R=$D/results
mkdir -p "$R"
rm -f "$R"/*.[0-9] "$R"/*.[0-9][0-9] "$R/stderr.log"
for p in "$D/raybench" "$D/embree_bench" "$D/imgdiff" "$D/walltime" "$D/objparse" "$BUILD/rayd-render"; do
    [ -x "$p" ] || { echo "bench-peers: $p is missing (run make bench-peers)"; exit 1; }
done
command -v povray >/dev/null || { echo "bench-peers: povray is missing (make bench-deps)"; exit 1; }

bash bench/bunny.sh "$BUILD"
kv() { awk -v k="$2" '$1 == k {print $2; f=1} END {if (!f) print "-"}' "$1"; }
med() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }

# --- meshes: raybench and embree_bench on the same scene, interleaved ------
# One run of each, RUNS times over, so a burst of load from elsewhere on the
# machine hits both; each figure is then the median over the runs.  Then
# the same with --cpu-time (one thread only).
medianize() { # FILES... -> "key median" for every key, in first-seen order
    cat "$@" | awk '{n[$1]++; v[$1, n[$1]] = $2; if (!($1 in o)) {o[$1] = ++k; key[k] = $1}}
        END {for (i = 1; i <= k; i++) {c = key[i]; m = n[c];
            for (a = 1; a <= m; a++) x[a] = v[c, a];
            for (a = 1; a <= m; a++) for (b = a + 1; b <= m; b++)
                if (x[b] + 0 < x[a] + 0) {y = x[a]; x[a] = x[b]; x[b] = y}
            print c, x[int((m + 1) / 2)]}}'
}
run() { # OUT PROGRAM ARGS...; stderr collects in results/stderr.log
    local out=$1; shift
    "$@" >"$out" 2>>"$R/stderr.log" || { echo "bench-peers: $* failed: $(tail -1 "$R/stderr.log")"; exit 1; }
}
meshes=(mesh-8 mesh-4)
[ -s "$D/bunny.json" ] && meshes+=(bunny)
for m in "${meshes[@]}"; do
    for r in $(seq "$RUNS"); do
        run "$R/$m.raybench.$r" "$D/raybench" "$D/$m.json" --runs 1 --threads-max 2
        run "$R/$m.embree.$r" "$D/embree_bench" "$D/$m.json" --runs 1
    done
    for r in $(seq "$RUNS"); do
        run "$R/$m.raybench-cpu.$r" "$D/raybench" "$D/$m.json" --runs 1 --threads-max 1 --cpu-time
        run "$R/$m.embree-cpu.$r" "$D/embree_bench" "$D/$m.json" --runs 1 --cpu-time
        run "$R/$m.robust-cpu.$r" "$D/embree_bench" "$D/$m.json" --runs 1 --cpu-time --robust
    done
    for t in raybench embree raybench-cpu embree-cpu robust-cpu; do
        medianize "$R/$m.$t".[0-9]* >"$R/$m.$t"
    done
done

# --- spheres: rayd-render and povray, one thread --------------------------
pov=$(mktemp -d)
trap 'rm -rf "$pov"' EXIT
cp bench/peers/spheres10.pov "$pov/"
# A run of rayd is FRAMES renders back to back, its time their mean: about
# as long as one POV-Ray trace.  On a machine shared with other work a 0.15 s
# render falls wholly into a quiet or a busy moment while a 2 s trace
# averages over both; timing both over the same stretch keeps the ratio
# about the renderers, not about which moments each one drew.
FRAMES=${FRAMES:-10}
rayd_t=() pov_t=() pov_c=()
for r in $(seq "$RUNS"); do
    walls=()
    for f in $(seq "$FRAMES"); do
        out=$("$BUILD/rayd-render" bench/scenes/spheres10.json -o "$R/spheres10-rayd.png" \
            --threads 1 --stats 2>&1)
        walls+=("$(awk '/^wall:/ {print $2}' <<<"$out")")
    done
    rayd_t+=("$(printf '%s\n' "${walls[@]}" | awk '{s += $1} END {printf "%.4f", s / NR}')")
    (cd "$pov" && povray +Ispheres10.pov +Ospheres10-pov.png +W1920 +H1080 -A +WT1 -D +FN \
        >povray.log 2>&1) || { echo "bench-peers: povray failed:"; tail -5 "$pov/povray.log"; exit 1; }
    pov_t+=("$(sed -n 's/.*Trace Time:.*(\([0-9.]*\) seconds).*/\1/p' "$pov/povray.log" | head -1)")
    pov_c+=("$(sed -n '/Trace Time:/,/CPU-seconds/s/.* with \([0-9.]*\) CPU-seconds.*/\1/p' \
        "$pov/povray.log" | head -1)")
    run "$R/spheres10.raybench-cpu.$r" "$D/raybench" bench/scenes/spheres10.json --runs 1 \
        --threads-max 1 --cpu-time
done
cp "$pov/spheres10-pov.png" "$pov/povray.log" "$R/"
rayd_s=$(printf '%s\n' "${rayd_t[@]}" | med)
pov_s=$(printf '%s\n' "${pov_t[@]}" | med)
pov_cpu=$(printf '%s\n' "${pov_c[@]}" | med)
medianize "$R/spheres10.raybench-cpu".[0-9]* >"$R/spheres10.raybench-cpu"
rayd_cpu=$(kv "$R/spheres10.raybench-cpu" image_s_1t)
"$D/imgdiff" "$R/spheres10-rayd.png" "$R/spheres10-pov.png" >"$R/spheres10.imgdiff" || true

# --- end to end: the whole rayd-render process, as a user waits -------------
# spheres10 on 2 threads: rayd-render's whole process (start to PNG written)
# against POV-Ray's reported trace time on 2 threads (+WT2; its parse and
# bounding not counted: generous to POV-Ray).  The 1.3M mesh as binary PLY
# and as OBJ: the whole process against Embree's load, medium build and
# 16-wide primary + shadow rays of every pixel, their one-thread time halved
# for 2 threads (ideal scaling: generous to Embree).  Embree reads no files:
# for the PLY its load is the core's PLY reader (timed by embree_bench), for
# the OBJ a parse by tinyobjloader, the loader applications built on Embree
# use (objparse.cc, one thread as it runs), as issue 16 words the target;
# the OBJ against the PLY load is printed too, the stricter reading (the
# peer given the binary file).
#
# One round a run, each side right after the other, so that a burst of
# load from elsewhere hits both: the OBJ parse, POV-Ray's +WT2 trace and
# rayd's sphere frame, then Embree's PLY load + build + rays (embree_bench
# --runs 1) and rayd's PLY, each run twice and timed the second time, then
# rayd's OBJ.  Each figure is the median of its RUNS.  On the VMs rayd runs
# on, pages freed a second or two ago are handed back to the host and cost
# dear to touch again (hugemem.c): a rayd run straight after the 2 s OBJ
# parse took 0.55-0.62 s for the PLY against 0.38-0.40 straight after
# another run, and embree_bench's load and build after rayd's small sphere
# frame 0.16 + 0.37 s against 0.07 + 0.22 after its own run.  So every
# timed process follows one that has just freed as much memory: both
# sides are timed warm, as a user rendering one frame after another is.
# The sphere frame too (since Nov 28 2026): POV-Ray's trace time is taken
# inside its process, after its parse has touched its memory, and rayd's
# frame is timed the second of two runs; the first, straight after
# POV-Ray, is printed beside it (cold).
whole() { # SCENE: one whole rayd-render process, its microseconds (fork to exit,
    # walltime.c) into $R/walltime
    "$D/walltime" "$R/walltime" "$BUILD/rayd-render" "$1" -o "$R/whole.png" --threads 2 \
        2>>"$R/stderr.log" || { echo "bench-peers: rayd-render $1 failed"; exit 1; }
}
seconds() { med | awk '{printf "%.4f", $1 / 1e6}'; }
pov2_t=() ws=() wsc=() wp=() wo=()
for r in $(seq "$RUNS"); do
    run "$R/e2e.objparse.$r" "$D/objparse" "$D/mesh-8.obj" --runs 1
    (cd "$pov" && povray +Ispheres10.pov +Ospheres10-pov2.png +W1920 +H1080 -A +WT2 -D +FN \
        >povray2.log 2>&1) || { echo "bench-peers: povray +WT2 failed"; exit 1; }
    pov2_t+=("$(sed -n 's/.*Trace Time:.*(\([0-9.]*\) seconds).*/\1/p' "$pov/povray2.log" | head -1)")
    whole bench/scenes/spheres10.json && wsc+=("$(cat "$R/walltime")")
    whole bench/scenes/spheres10.json && ws+=("$(cat "$R/walltime")")
    run "$R/e2e.embree.$r" "$D/embree_bench" "$D/mesh-8.json" --runs 1
    run "$R/e2e.embree.$r" "$D/embree_bench" "$D/mesh-8.json" --runs 1
    whole "$D/mesh-8.json"
    whole "$D/mesh-8.json" && wp+=("$(cat "$R/walltime")")
    whole "$D/mesh-8-obj.json" && wo+=("$(cat "$R/walltime")")
done
pov2_s=$(printf '%s\n' "${pov2_t[@]}" | med)
whole_spheres=$(printf '%s\n' "${ws[@]}" | seconds)
whole_spheres_cold=$(printf '%s\n' "${wsc[@]}" | seconds)
whole_ply=$(printf '%s\n' "${wp[@]}" | seconds)
whole_obj=$(printf '%s\n' "${wo[@]}" | seconds)
medianize "$R/e2e.embree".[0-9]* >"$R/e2e.embree"
medianize "$R/e2e.objparse".[0-9]* >"$R/e2e.objparse"
em8=$R/e2e.embree
embree_e2e() { # LOAD_SECONDS -> that + Embree's medium build + its rays on 2 threads
    awk -v p="$1" -v b="$(kv "$em8" bvh_build_s)" -v r="$(kv "$em8" shadow_mrays_1t_packet16)" \
        'BEGIN {printf "%.4f", p + b + 1920 * 1080 / (r * 1e6) / 2}'
}
embree_e2e=$(embree_e2e "$(kv "$em8" parse_s)")
embree_e2e_obj=$(embree_e2e "$(kv "$R/e2e.objparse" obj_parse_s)")

# --- absolute figures ------------------------------------------------------
echo "Absolute figures (1920x1080, one thread unless noted, medians of $RUNS runs)"
printf '%-7s %8s | %-70s | %-70s\n' "" "" "rayd (raybench)" "Embree $(awk '$1=="peer" {print $3}' "$R/mesh-8.embree.1") (embree_bench)"
printf '%-7s %8s | %7s %6s %6s %6s %6s %6s %6s %6s %6s %6s | %7s %6s %6s %6s %6s %6s %6s %6s %6s %6s\n' mesh tris \
    "build s" "B/tri" prim1 prim16 shad1 shad16 occl1 occl16 bnc1 bnc16 \
    "build s" "B/tri" prim1 prim16 shad1 shad16 occl1 occl16 bnc1 bnc16
for m in "${meshes[@]}"; do
    a=$R/$m.raybench e=$R/$m.embree
    printf '%-7s %8s | %7s %6s %6s %6s %6s %6s %6s %6s %6s %6s | %7s %6s %6s %6s %6s %6s %6s %6s %6s %6s\n' "$m" \
        "$(kv "$a" triangles)" "$(kv "$a" bvh_build_s)" "$(kv "$a" bytes_per_triangle)" \
        "$(kv "$a" primary_mrays_1t)" "$(kv "$a" primary_packet_mrays_1t)" \
        "$(kv "$a" shadow_mrays_1t)" "$(kv "$a" shadow_packet_mrays_1t)" \
        "$(kv "$a" occlusion_mrays_1t)" "$(kv "$a" occlusion_packet_mrays_1t)" \
        "$(kv "$a" bounce_mrays_1t)" "$(kv "$a" bounce_packet_mrays_1t)" \
        "$(kv "$e" bvh_build_s)" "$(kv "$e" bytes_per_triangle)" \
        "$(kv "$e" primary_mrays_1t_single)" "$(kv "$e" primary_mrays_1t_packet16)" \
        "$(kv "$e" shadow_mrays_1t_single)" "$(kv "$e" shadow_mrays_1t_packet16)" \
        "$(kv "$e" occlusion_mrays_1t_single)" "$(kv "$e" occlusion_mrays_1t_packet16)" \
        "$(kv "$e" bounce_mrays_1t_single)" "$(kv "$e" bounce_mrays_1t_packet16)"
    for kind in primary occlusion bounce; do
        ah=$(kv "$a" ${kind}_hits) eh=$(kv "$e" ${kind}_mrays_1t_single_hits)
        awk -v a="$ah" -v e="$eh" -v m="$m" -v k="$kind" 'BEGIN {d = a - e; if (d < 0) d = -d;
            if (d > 0.001 * e) printf "  warning: %s %s hits differ: rayd %d, Embree %d\n", m, k, a, e}'
    done
    printf '  (%s: bounce rays %s, hits rayd %s, Embree %s)\n' "$m" "$(kv "$a" bounce_rays)" \
        "$(kv "$a" bounce_hits)" "$(kv "$e" bounce_mrays_1t_single_hits)"
done
echo "  (Mrays/s; 1: one ray at a time, 16: packets of 4x4 pixels, or for bounce rays 16"
echo "   consecutive ones; build: 2 threads each, BVH only; B/tri: mesh data + BVH, each;"
echo "   shadow: pixels/s (M) for a primary ray plus a shadow ray from each hit; occl: the same"
echo "   shadow rays alone, rays/s, made before the clock starts; bounce: rays/s of the"
echo "   diffuse-bounce rays alone, one from each primary hit, bench/bounce.h)"
printf 'spheres10 (100 spheres, max_depth 5): rayd-render --threads 1 wall %s s (runs, each the mean\n' \
    "$rayd_s"
printf '  of %s renders: %s);\n' "$FRAMES" "${rayd_t[*]}"
printf '  povray +WT1 -A trace %s s (runs: %s); images: mean |diff| %s/255, %s%% of pixels differ\n' \
    "$pov_s" "${pov_t[*]}" "$(kv "$R/spheres10.imgdiff" mean_abs_diff)" \
    "$(kv "$R/spheres10.imgdiff" pixels_differ_pct)"
printf '  CPU seconds: rayd (raybench, 1-thread image) %s, POV-Ray trace %s\n' "$rayd_cpu" "$pov_cpu"

# --- ratios ------------------------------------------------------------------
echo
echo "rayd / peer (speed ratios from this run; > 1: rayd faster)"
printf '%-40s %6s %6s %8s  %s\n' comparison wall cpu target "verdict (wall; cpu if it differs)"
row() { # label rayd peer rayd_cpu peer_cpu target(or -) [inverse: 1 when figures are times]
    awk -v l="$1" -v a="$2" -v p="$3" -v ac="$4" -v pc="$5" -v t="$6" -v inv="${7:-0}" '
    function ratio(x, y) { if (x == "-" || y == "-" || x + 0 <= 0 || y + 0 <= 0) return -1
                           return inv ? y / x : x / y }
    function fmt(r) { return r < 0 ? "n/a" : sprintf("%.2f", r) }
    BEGIN { r = ratio(a, p); rc = ratio(ac, pc); v = ""
        if (t != "-" && r >= 0) {
            v = r >= t ? "met" : "NOT met"
            if (rc >= 0 && (rc >= t) != (r >= t)) v = v " (cpu: " (rc >= t ? "met" : "NOT met") ")"
        }
        printf "%-40s %6s %6s %8s  %s\n", l, fmt(r), fmt(rc), t == "-" ? "" : ">= " t, v }'
}
name_of() { case $1 in mesh-8) echo "1.3M mesh";; mesh-4) echo "5k mesh";; bunny) echo "bunny";; esac; }
for kind in primary shadow occlusion bounce; do
    for m in "${meshes[@]}"; do
        a=$R/$m.raybench e=$R/$m.embree ac=$R/$m.raybench-cpu ec=$R/$m.embree-cpu n=$(name_of "$m")
        t=-
        [ "$kind" = primary ] && t=0.5
        row "$kind, $n: single / single" "$(kv "$a" ${kind}_mrays_1t)" \
            "$(kv "$e" ${kind}_mrays_1t_single)" "$(kv "$ac" ${kind}_mrays_1t)" \
            "$(kv "$ec" ${kind}_mrays_1t_single)" -
        row "$kind, $n: packets / packet16" "$(kv "$a" ${kind}_packet_mrays_1t)" \
            "$(kv "$e" ${kind}_mrays_1t_packet16)" "$(kv "$ac" ${kind}_packet_mrays_1t)" \
            "$(kv "$ec" ${kind}_mrays_1t_packet16)" "$t"
    done
done
# Against Embree's robust mode (embree_bench --robust): the nearest it comes
# to the guarantees rayd's walks always give (no ray through a shared edge);
# CPU seconds, one thread.
for kind in primary shadow occlusion bounce; do
    for m in "${meshes[@]}"; do
        ac=$R/$m.raybench-cpu rc=$R/$m.robust-cpu n=$(name_of "$m")
        row "$kind, $n: 1 / robust 1" - - "$(kv "$ac" ${kind}_mrays_1t)" \
            "$(kv "$rc" ${kind}_mrays_1t_single)" -
        row "$kind, $n: 16 / robust 16" - - "$(kv "$ac" ${kind}_packet_mrays_1t)" \
            "$(kv "$rc" ${kind}_mrays_1t_packet16)" -
    done
done
row "BVH build, 1.3M mesh / Embree medium" "$(kv "$R/mesh-8.raybench" bvh_build_s)" \
    "$(kv "$R/mesh-8.embree" bvh_build_s)" - - 1 1
row "spheres10, 1 thread / POV-Ray trace" "$rayd_s" "$pov_s" "$rayd_cpu" "$pov_cpu" 10 1
row "scaling: rayd packets 1.3M / 5k mesh" "$(kv "$R/mesh-8.raybench" primary_packet_mrays_1t)" \
    "$(kv "$R/mesh-4.raybench" primary_packet_mrays_1t)" \
    "$(kv "$R/mesh-8.raybench-cpu" primary_packet_mrays_1t)" \
    "$(kv "$R/mesh-4.raybench-cpu" primary_packet_mrays_1t)" 0.6
row "scaling: rayd single 1.3M / 5k mesh" "$(kv "$R/mesh-8.raybench" primary_mrays_1t)" \
    "$(kv "$R/mesh-4.raybench" primary_mrays_1t)" "$(kv "$R/mesh-8.raybench-cpu" primary_mrays_1t)" \
    "$(kv "$R/mesh-4.raybench-cpu" primary_mrays_1t)" 0.6
row "  (Embree packet16 1.3M / 5k, reference)" "$(kv "$R/mesh-8.embree" primary_mrays_1t_packet16)" \
    "$(kv "$R/mesh-4.embree" primary_mrays_1t_packet16)" \
    "$(kv "$R/mesh-8.embree-cpu" primary_mrays_1t_packet16)" \
    "$(kv "$R/mesh-4.embree-cpu" primary_mrays_1t_packet16)" -
row "whole: spheres10 2t / POV-Ray trace 2t" "$whole_spheres" "$pov2_s" - - 10 1
row "  (spheres10 cold: right after POV-Ray)" "$whole_spheres_cold" "$pov2_s" - - - 1
row "whole: 1.3M PLY / Embree load+build+rays" "$whole_ply" "$embree_e2e" - - 1 1
row "whole: 1.3M OBJ / Embree OBJ+build+rays" "$whole_obj" "$embree_e2e_obj" - - 1 1
row "  (the OBJ / Embree PLY load+build+rays)" "$whole_obj" "$embree_e2e" - - - 1
printf '(whole: rayd-render start to PNG written, 2 threads: spheres10 %s s (cold %s s), 1.3M PLY %s s, OBJ %s s;\n' \
    "$whole_spheres" "$whole_spheres_cold" "$whole_ply" "$whole_obj"
printf ' POV-Ray +WT2 trace %s s; Embree PLY load %s s or OBJ parse (tinyobjloader) %s s\n' \
    "$pov2_s" "$(kv "$em8" parse_s)" "$(kv "$R/e2e.objparse" obj_parse_s)"
printf ' + medium build %s s + rays %s Mpixels/s 1t)\n' \
    "$(kv "$em8" bvh_build_s)" "$(kv "$em8" shadow_mrays_1t_packet16)"
echo "(BVH build: wall only, both builds use 2 threads)"
echo "(raw figures and both sphere images in $R/)"
