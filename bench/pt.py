#!/usr/bin/env python3
"""bench/pt.py BUILD -- rayd's path tracer against Cycles (and Mitsuba 3) at equal quality.

`make bench-pt` runs it (part of `make bench-peers`); Blender comes from
`make bench-deps`.  Four scenes, each written once as rayd JSON (the one
description: bench/peers/cycles_pt.py builds the same scene in Blender
from that file, number for number):

  cornell   scenes/cornell.json without its glass sphere (diffuse walls,
            the gold sphere, the quad light)
  glass     scenes/cornell.json as shipped (the glass sphere: caustics)
  bunny     the Stanford bunny (bench/bunny.sh) on a floor under
            scenes/studio.hdr, no other light
  gap       a closed room lit only through a narrow slit in one wall by a
            quad light outside it: the hard case for light sampling

For each: a shared reference, the mean of rayd's and Cycles' images at
REF_SPP samples each (rayd's in one render with --max-samples where
rayd-render has it, else the mean of REF_SPP/1024 renders of 1024 samples
with different seeds), after
checking the two agree (mean per channel); then, RUNS times, interleaved
(for each run, sample count and scene: rayd, then Cycles), a render at
each of SPP samples, timed as a whole process (walltime: fork to exit)
and as the render alone: Cycles' log's PT_RENDER_S (scene sync, BVH
build, sampling, EXR written), rayd-render's --stats "time total" (read,
parse, build, sampling, EXR written), each without its program's
start-up.  Errors against the reference
over the pixels that are not the emitter (reference above MASK): MSE and
RMSE of linear RGB, and the relative MSE, mean of (x - ref)^2 / (ref^2 +
0.01).  Efficiency = 1 / (time x MSE), from the medians of the RUNS runs;
the ratio is rayd's over Cycles' (> 1: rayd reaches an error sooner).

Mitsuba 3 joins them where a build of it is at hand (Debian has none, and
its source needs GitHub): MITSUBA names its `mitsuba` program (else one on
PATH; bench/peers/mitsuba_build.sh builds one from a checkout),
MITSUBA_VARIANT its variant (scalar_rgb; llvm_ad_rgb, its JIT variant, where
it was built with it); bench/peers/mitsuba_pt.py writes each scene for it.
Its render alone is its log's "Rendering finished (took ...)": the
sampling (for a JIT variant, its kernel's compilation too, unless cached
from an earlier run), without the scene's load and build.
Its images are checked against the shared reference as Cycles' are.

Environment: RUNS (3), SPP ("4 16 64 256"), REF_SPP (4096), SIZE (128),
SCENES ("cornell glass bunny gap"), THREADS (2), MITSUBA, MITSUBA_VARIANT.  References are kept in
BUILD/bench/pt/ref/, named by the scene's text and REF_SPP, and reused.
"""
import array
import copy
import hashlib
import json
import math
import os
import shutil
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "build")
D = os.path.join(BUILD, "bench", "pt")
RUNS = int(os.environ.get("RUNS", "3"))
SPP = [int(x) for x in os.environ.get("SPP", "4 16 64 256").split()]
REF_SPP = int(os.environ.get("REF_SPP", "4096"))
SIZE = int(os.environ.get("SIZE", "128"))
SCENES = os.environ.get("SCENES", "cornell glass bunny gap").split()
THREADS = int(os.environ.get("THREADS", "2"))
RAYD = os.path.join(BUILD, "rayd-render")
WALLTIME = os.path.join(BUILD, "bench", "walltime")
EXRRAW = os.path.join(BUILD, "bench", "exrraw")
CYCLES_PY = os.path.join(ROOT, "bench", "peers", "cycles_pt.py")
MITSUBA_PY = os.path.join(ROOT, "bench", "peers", "mitsuba_pt.py")
MITSUBA = os.environ.get("MITSUBA") or shutil.which("mitsuba")
MITSUBA_VARIANT = os.environ.get("MITSUBA_VARIANT", "scalar_rgb")


def die(msg):
    print("bench-pt: " + msg, file=sys.stderr)
    sys.exit(1)


# --- the scenes ----------------------------------------------------------
def render_block(max_depth):
    return {"width": SIZE, "height": SIZE, "samples": 1, "max_depth": max_depth,
            "integrator": "path", "background": [0, 0, 0]}


def cornell(glass):
    with open(os.path.join(ROOT, "scenes", "cornell.json")) as f:
        s = json.load(f)
    s["render"] = render_block(s["render"]["max_depth"])
    if not glass:
        s["objects"] = [o for o in s["objects"]
                        if not (o["type"] == "sphere" and o["material"].get("transparency"))]
    return s, 2.0


def quad(corner, e1, e2, mat):
    return {"type": "quad", "corner": corner, "edge1": e1, "edge2": e2, "material": mat}


def bunny():
    # The npm bunny spans x -5..5, y 0..9.7, z -3.7..3.8 (bench/bunny.sh).
    s = {"camera": {"position": [0, 7, 24], "look_at": [0, 4, 0], "fov_x": 45},
         "render": render_block(8),
         "materials": {"clay": {"color": [0.8, 0.7, 0.6], "diffuse": 1},
                       "floor": {"color": [0.5, 0.5, 0.5], "diffuse": 1}},
         "objects": [quad([-20, 0, -20], [40, 0, 0], [0, 0, 40], "floor"),
                     {"type": "mesh", "source": {"file": "bunny.ply"}, "smooth": False,
                      "material": "clay"}]}
    s["render"]["environment"] = {"file": "studio.hdr"}
    return s, None


def gap():
    # A room x -2..2, y 0..2.5, z -2..2; the wall at x = 2 has a vertical
    # slit 0.1 wide (z -0.05..0.05) and a 1 x 1.5 quad light of radiance
    # 40 stands 1 outside it.  Thin walls: quads.
    w = "white"
    objs = [quad([-2, 0, -2], [4, 0, 0], [0, 0, 4], "floor"),
            quad([-2, 2.5, -2], [4, 0, 0], [0, 0, 4], w),
            quad([-2, 0, -2], [4, 0, 0], [0, 2.5, 0], w),
            quad([-2, 0, 2], [4, 0, 0], [0, 2.5, 0], w),
            quad([-2, 0, -2], [0, 0, 4], [0, 2.5, 0], "red"),
            quad([2, 0, -2], [0, 0, 1.95], [0, 2.5, 0], w),
            quad([2, 0, 0.05], [0, 0, 1.95], [0, 2.5, 0], w),
            quad([3, 0.5, -0.5], [0, 0, 1], [0, 1.5, 0], "light"),
            {"type": "box", "center": [0, 0.4, -0.8], "size": [0.8, 0.8, 0.8],
             "transform": {"rotate": [0, 30, 0], "translate": [0.3, 0, 0]}, "material": w}]
    s = {"camera": {"position": [-1.2, 1.3, 1.9], "look_at": [0.6, 0.8, -1.2], "fov_x": 70},
         "render": render_block(8),
         "materials": {"white": {"color": [0.75, 0.75, 0.75], "diffuse": 1},
                       "floor": {"color": [0.6, 0.55, 0.45], "diffuse": 1},
                       "red": {"color": [0.6, 0.1, 0.1], "diffuse": 1},
                       "light": {"color": [0, 0, 0], "emission": [40, 40, 40]}},
         "objects": objs}
    return s, 2.0


def make_scene(name):
    if name == "cornell":
        return cornell(False)
    if name == "glass":
        return cornell(True)
    if name == "bunny":
        return bunny()
    if name == "gap":
        return gap()
    die("unknown scene %s (SCENES: cornell glass bunny gap)" % name)


def write_scene(s, samples, seed, path):
    s = copy.deepcopy(s)
    s["render"]["samples"] = samples
    s["render"]["seed"] = seed
    with open(path, "w") as f:
        json.dump(s, f, indent=1)
    return path


# --- running both renderers ---------------------------------------------
def timed(cmd, log):
    """Run cmd under walltime; its seconds (fork to exit)."""
    tfile = os.path.join(D, "walltime")
    with open(log, "w") as lf:
        rc = subprocess.call([WALLTIME, tfile] + cmd, stdout=lf, stderr=subprocess.STDOUT)
    if rc != 0:
        with open(log) as lf:
            tail = lf.read().strip().splitlines()[-5:]
        die("%s failed (exit %d):\n  %s" % (" ".join(cmd), rc, "\n  ".join(tail)))
    with open(tfile) as f:
        return int(f.read().split()[0]) / 1e6


def read_raw(exr):
    raw = exr + ".raw"
    if subprocess.call([EXRRAW, exr, raw]) != 0:
        die("could not read %s" % exr)
    with open(raw, "rb") as f:
        data = f.read()
    nl = data.index(b"\n")
    w, h = (int(x) for x in data[:nl].split())
    a = array.array("f")
    a.frombytes(data[nl + 1:])
    if sys.byteorder != "little":
        a.byteswap()
    os.remove(raw)
    if len(a) != w * h * 3:
        die("%s: %d floats for %d x %d" % (exr, len(a), w, h))
    return a


def log_seconds(log, key):
    """The number after the last line of log that starts with key."""
    found = None
    with open(log) as f:
        for line in f:
            if line.startswith(key):
                found = float(line[len(key):].split()[0])
    if found is None:
        die("no '%s' in %s" % (key.strip(), log))
    return found


def run_rayd(s, name, samples, seed, extra=()):
    js = write_scene(s, samples, seed, os.path.join(D, name + ".rayd.json"))
    out = os.path.join(D, name + ".rayd.exr")
    log = os.path.join(D, name + ".rayd.log")
    t = timed([RAYD, js, "-o", out, "--threads", str(THREADS), "--quiet", "--stats"]
              + list(extra), log)
    return read_raw(out), t, log_seconds(log, "time total:")


def run_cycles(s, name, samples, seed):
    js = write_scene(s, 1, 0, os.path.join(D, name + ".cycles.json"))
    out = os.path.join(D, name + ".cycles.exr")
    log = os.path.join(D, name + ".cycles.log")
    t = timed(["blender", "-b", "-noaudio", "--factory-startup", "-P", CYCLES_PY, "--",
               js, out, str(samples), str(seed), str(THREADS)], log)
    return read_raw(out), t, log_seconds(log, "PT_RENDER_S ")


def took_seconds(log):
    """Mitsuba's "Rendering finished. (took 1m 2.5s)" (or 850ms) in seconds."""
    found = None
    with open(log) as f:
        for line in f:
            if "Rendering finished. (took " in line:
                found = line.split("(took ", 1)[1].split(")")[0]
    if found is None:
        die("no 'Rendering finished' in %s" % log)
    units = {"ms": 1e-3, "s": 1, "m": 60, "h": 3600, "d": 86400}
    total = 0.0
    for part in found.split():
        num = part.rstrip("msdh")
        total += float(num) * units[part[len(num):]]
    return total


def run_mitsuba(s, name, samples, seed):
    js = write_scene(s, 1, 0, os.path.join(D, name + ".mitsuba.json"))
    xml = os.path.join(D, name + ".mitsuba.xml")
    if subprocess.call([sys.executable, MITSUBA_PY, js, xml]) != 0:
        die("mitsuba_pt.py could not write %s" % xml)
    out = os.path.join(D, name + ".mitsuba.exr")
    log = os.path.join(D, name + ".mitsuba.log")
    t = timed([MITSUBA, "-m", MITSUBA_VARIANT, "-t", str(THREADS), "-D", "spp=%d" % samples,
               "-D", "seed=%d" % seed, "-o", out, xml], log)
    return read_raw(out), t, took_seconds(log)


# --- references and errors ----------------------------------------------
def cached(path, what, render):
    """The image kept at path, else render()'s, kept there for the next run."""
    a = array.array("f")
    if os.path.exists(path):
        with open(path, "rb") as fh:
            a.frombytes(fh.read())
        return a
    print("  %s reference, %d samples ..." % (what, REF_SPP), flush=True)
    a = render()
    with open(path, "wb") as fh:
        fh.write(a.tobytes())
    return a


def ref_path(s, name, translator, extra, suffix):
    """BUILD/bench/pt/ref/NAME-KEY-REF_SPP.SUFFIX, KEY from the scene and its translator."""
    with open(translator, "rb") as f:  # a changed translation makes new references
        text = json.dumps(s, sort_keys=True).encode() + f.read() + extra
    key = hashlib.sha256(text).hexdigest()[:12]
    os.makedirs(os.path.join(D, "ref"), exist_ok=True)
    return os.path.join(D, "ref", "%s-%s-%d.%s" % (name, key, REF_SPP, suffix))


def rayd_reference(s, name):
    """rayd's REF_SPP image: one render, or the mean of 1024-sample ones for a
    rayd-render that takes no more (no --max-samples)."""
    if REF_SPP > 1024 and rayd_max_samples():
        return run_rayd(s, name + "-ref", REF_SPP, 1000, ["--max-samples", str(REF_SPP)])[0]
    k = max(1, math.ceil(REF_SPP / 1024))
    acc = None
    for i in range(k):
        img = run_rayd(s, name + "-ref", min(REF_SPP, 1024), 1000 + i)[0]
        acc = list(img) if acc is None else [x + y for x, y in zip(acc, img)]
    return array.array("f", [x / k for x in acc])


def reference(s, name):
    """rayd's and Cycles' own REF_SPP images of the scene."""
    return (cached(ref_path(s, name, CYCLES_PY, b"", "rayd"), name + ": rayd",
                   lambda: rayd_reference(s, name)),
            cached(ref_path(s, name, CYCLES_PY, b"", "cycles"), name + ": cycles",
                   lambda: run_cycles(s, name + "-ref", REF_SPP, 1000)[0]))


def mitsuba_reference(s, name):
    """Mitsuba's own REF_SPP image, for the agreement check alone."""
    return cached(ref_path(s, name, MITSUBA_PY, MITSUBA_VARIANT.encode(), "mitsuba"),
                  name + ": mitsuba", lambda: run_mitsuba(s, name + "-ref", REF_SPP, 1000)[0])


def rayd_max_samples():
    """Whether this rayd-render takes --max-samples (more than 1024 samples)."""
    r = subprocess.run([RAYD, "--help"], capture_output=True, text=True)
    return "--max-samples" in r.stdout + r.stderr


def mask_of(ref, limit):
    n = len(ref) // 3
    if limit is None:
        return [True] * n
    return [max(ref[3 * i], ref[3 * i + 1], ref[3 * i + 2]) <= limit for i in range(n)]


def channel_means(img, mask):
    s = [0.0, 0.0, 0.0]
    for i, keep in enumerate(mask):
        if keep:
            for c in range(3):
                s[c] += img[3 * i + c]
    n = sum(mask)
    return [x / n for x in s]


def errors(img, ref, mask):
    se = rel = 0.0
    n = 0
    for i, keep in enumerate(mask):
        if not keep:
            continue
        for c in range(3):
            r = ref[3 * i + c]
            d = img[3 * i + c] - r
            se += d * d
            rel += d * d / (r * r + 0.01)
            n += 1
    return se / n, rel / n


# --- the bench -----------------------------------------------------------
def main():
    if shutil.which("blender") is None:
        die("blender is missing: run make bench-deps (Debian's blender package)")
    for p in (RAYD, WALLTIME, EXRRAW):
        if not os.access(p, os.X_OK):
            die("%s is missing (run make bench-pt)" % p)
    os.makedirs(D, exist_ok=True)
    scenes = {}
    for name in SCENES:
        if name == "bunny":
            ply = os.path.join(BUILD, "bench", "bunny.ply")
            if not os.path.exists(ply):
                print("bench-pt: no %s (bench/bunny.sh needs npm): skipping the bunny" % ply)
                continue
            shutil.copyfile(ply, os.path.join(D, "bunny.ply"))
            shutil.copyfile(os.path.join(ROOT, "scenes", "studio.hdr"),
                            os.path.join(D, "studio.hdr"))
        scenes[name] = make_scene(name)
    peers = [("rayd", run_rayd), ("cycles", run_cycles)]
    if MITSUBA:
        peers.append(("mitsuba", run_mitsuba))
    print("rayd path tracer vs Cycles (%s)%s, %dx%d, %d threads, max depth as each scene's"
          % (blender_version(), ", Mitsuba 3 (%s)" % MITSUBA_VARIANT if MITSUBA else "",
             SIZE, SIZE, THREADS))
    if not MITSUBA:
        print("(no Mitsuba 3: set MITSUBA to its mitsuba program to compare with it too)")
    refs, agree = {}, {}
    for name, (s, limit) in scenes.items():
        a, b = reference(s, name)
        ref = array.array("f", [(x + y) / 2 for x, y in zip(a, b)])
        mask = mask_of(ref, limit)
        ma, mb = channel_means(a, mask), channel_means(b, mask)
        refnoise = errors(a, b, mask)[0] / 4  # variance of the mean of the two
        refs[name] = (ref, mask)
        mm = channel_means(mitsuba_reference(s, name), mask) if MITSUBA else None
        agree[name] = (ma, mb, refnoise, mm)
    results = {}  # (scene, who, spp) -> list of (wall, alone, mse, rel)
    for run in range(1, RUNS + 1):
        for spp in SPP:
            for name, (s, _) in scenes.items():
                ref, mask = refs[name]
                for who, fn in peers:
                    img, wall, alone = fn(s, name, spp, run)
                    mse, rel = errors(img, ref, mask)
                    results.setdefault((name, who, spp), []).append((wall, alone, mse, rel))
        print("  run %d of %d done" % (run, RUNS), flush=True)
    report(scenes, agree, results)
    if MITSUBA:
        report_mitsuba(scenes, agree, results)


def blender_version():
    try:
        out = subprocess.run(["blender", "--version"], capture_output=True, text=True).stdout
        return out.splitlines()[0].strip()
    except (OSError, IndexError):
        return "Blender"


def med(rows, k):
    return statistics.median(r[k] for r in rows)


def report(scenes, agree, results):
    print()
    print("Agreement at %d samples each (mean per channel, emitter masked):" % REF_SPP)
    for name in scenes:
        ma, mb, refnoise, _ = agree[name]
        diff = " ".join("%+.2f%%" % (100 * (x / y - 1) if y else 0) for x, y in zip(ma, mb))
        print("  %-8s rayd %s  Cycles %s  rayd/Cycles - 1: %s  (reference noise %.2e)" % (
            name, " ".join("%.4f" % x for x in ma), " ".join("%.4f" % x for x in mb), diff,
            refnoise))
    print()
    print("Medians of %d interleaved runs; wall: whole process; render: the render alone;" % RUNS)
    print("MSE: linear RGB against the shared reference; eff = 1 / (wall x MSE)")
    hdr = "%-8s %5s | %7s %7s %9s %9s %9s | %7s %7s %9s %9s %9s | %6s %6s %6s"
    print(hdr % ("scene", "spp", "rayd s", "render", "RMSE", "relMSE", "eff", "Cyc s", "render",
                 "RMSE", "relMSE", "eff", "ratio", "r/rnd", "rnd"))
    for name in scenes:
        for spp in SPP:
            a, b = results[(name, "rayd", spp)], results[(name, "cycles", spp)]
            ta, tar, ma, ra = med(a, 0), med(a, 1), med(a, 2), med(a, 3)
            tb, tbr, mb, rb = med(b, 0), med(b, 1), med(b, 2), med(b, 3)
            ea, ear, eb, ebr = 1 / (ta * ma), 1 / (tar * ma), 1 / (tb * mb), 1 / (tbr * mb)
            print("%-8s %5d | %7.2f %7.2f %9.5f %9.5f %9.3g | %7.2f %7.2f %9.5f %9.5f %9.3g |"
                  " %6.2f %6.2f %6.2f"
                  % (name, spp, ta, tar, math.sqrt(ma), ra, ea, tb, tbr, math.sqrt(mb), rb, eb,
                     ea / eb, ea / ebr, ear / ebr))
    print("(ratio: rayd's whole process over Cycles' whole process; r/rnd: rayd's whole process")
    print(" over Cycles' render alone; rnd: render alone over render alone, both programs'")
    print(" start-up left out; each the efficiency's ratio, > 1: rayd reaches that error sooner)")



def report_mitsuba(scenes, agree, results):
    print()
    print("Mitsuba 3 (%s) at %d samples, against the same reference (mean per channel):"
          % (MITSUBA_VARIANT, REF_SPP))
    for name in scenes:
        ma, mb, _, mm = agree[name]
        ref = [(x + y) / 2 for x, y in zip(ma, mb)]
        diff = " ".join("%+.2f%%" % (100 * (x / y - 1) if y else 0) for x, y in zip(mm, ref))
        print("  %-8s Mitsuba %s  Mitsuba/reference - 1: %s" % (
            name, " ".join("%.4f" % x for x in mm), diff))
    print()
    hdr = "%-8s %5s | %7s %7s %9s %9s | %7s %7s %9s %9s | %6s %6s"
    print(hdr % ("scene", "spp", "rayd s", "render", "RMSE", "eff", "Mit s", "render", "RMSE",
                 "eff", "ratio", "rnd"))
    for name in scenes:
        for spp in SPP:
            a, b = results[(name, "rayd", spp)], results[(name, "mitsuba", spp)]
            ta, tar, ma = med(a, 0), med(a, 1), med(a, 2)
            tb, tbr, mb = med(b, 0), med(b, 1), med(b, 2)
            print("%-8s %5d | %7.2f %7.2f %9.5f %9.3g | %7.2f %7.2f %9.5f %9.3g | %6.2f %6.2f"
                  % (name, spp, ta, tar, math.sqrt(ma), 1 / (ta * ma), tb, tbr, math.sqrt(mb),
                     1 / (tb * mb), tb * mb / (ta * ma), tbr * mb / (tar * ma)))
    print("(ratio: rayd's efficiency over Mitsuba's, whole processes; rnd: render alone over")
    print(" render alone, Mitsuba's without its scene load and build; > 1: rayd reaches that")
    print(" error sooner)")


if __name__ == "__main__":
    main()
