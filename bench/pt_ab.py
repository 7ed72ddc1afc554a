#!/usr/bin/env python3
"""bench/pt_ab.py BUILD OLD_RENDER -- one path-tracer change, before and after.

Renders bench/pt.py's scenes (cornell, glass, bunny, gap) with OLD_RENDER
(a rayd-render built before the change) and BUILD/rayd-render (after), at
each of SPP samples with SEEDS seeds, old and new interleaved seed by seed,
and measures each image's MSE (linear RGB, the lamp masked as bench/pt.py
masks it) against one reference: BUILD/rayd-render at REF samples (any
unbiased estimator serves).  Prints, per scene and sample count, the mean
MSE of each, the ratio old/new (> 1: the new samples are better), the
median whole-process times and the efficiency ratio, 1 / (time x MSE) new
over old.  For item 2 of the path tracer's work (better samples), where no
peer is needed: `make bench-pt` compares with Cycles.

Environment: SCENES, SPP ("4 16 64"), SEEDS (4), REF (2048), SIZE and
THREADS as bench/pt.py.  References are kept in BUILD/bench/pt_ab/.
"""
import array
import os
import shutil
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
if len(sys.argv) != 3:
    sys.exit("usage: bench/pt_ab.py BUILD OLD_RENDER")
BUILD, OLD = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
sys.argv = sys.argv[:2]
import pt  # noqa: E402  (reads BUILD from sys.argv)

pt.D = os.path.join(BUILD, "bench", "pt_ab")
NEW = os.path.join(BUILD, "rayd-render")
REF = int(os.environ.get("REF", "2048"))
SEEDS = int(os.environ.get("SEEDS", "4"))
SPP = [int(x) for x in os.environ.get("SPP", "4 16 64").split()]
SCENES = os.environ.get("SCENES", "cornell glass bunny gap").split()


def reference(s, name):
    path = os.path.join(pt.D, "ref-%s-%d-%d.f" % (name, pt.SIZE, REF))
    if os.path.exists(path):
        a = array.array("f")
        with open(path, "rb") as f:
            a.frombytes(f.read())
        return a
    pt.RAYD = NEW
    a = pt.run_rayd(s, name + "-ref", REF, 999, ["--max-samples", str(REF)])[0]
    with open(path, "wb") as f:
        f.write(a.tobytes())
    return a


def main():
    os.makedirs(pt.D, exist_ok=True)
    for p in (NEW, OLD):
        if not os.access(p, os.X_OK):
            sys.exit("pt_ab: %s is not a program" % p)
    print("old %s, new %s; %dx%d, %d threads, reference %d samples, %d seeds"
          % (OLD, NEW, pt.SIZE, pt.SIZE, pt.THREADS, REF, SEEDS))
    print("%-8s %5s  %10s %10s %9s  %8s %8s  %9s"
          % ("scene", "spp", "MSE old", "MSE new", "old/new", "t old", "t new", "eff n/o"))
    for name in SCENES:
        if name == "bunny":
            ply = os.path.join(BUILD, "bench", "bunny.ply")
            if not os.path.exists(ply):
                print("pt_ab: no %s (bash bench/bunny.sh BUILD): skipping the bunny" % ply)
                continue
            shutil.copyfile(ply, os.path.join(pt.D, "bunny.ply"))
            shutil.copyfile(os.path.join(pt.ROOT, "scenes", "studio.hdr"),
                            os.path.join(pt.D, "studio.hdr"))
        s, limit = pt.make_scene(name)
        ref = reference(s, name)
        mask = pt.mask_of(ref, limit)
        for spp in SPP:
            mse = {"old": [], "new": []}
            sec = {"old": [], "new": []}
            for seed in range(SEEDS):
                for who, prog in (("old", OLD), ("new", NEW)):
                    pt.RAYD = prog
                    img, t, _ = pt.run_rayd(s, name, spp, seed)
                    mse[who].append(pt.errors(img, ref, mask)[0])
                    sec[who].append(t)
            mo, mn = statistics.mean(mse["old"]), statistics.mean(mse["new"])
            to, tn = statistics.median(sec["old"]), statistics.median(sec["new"])
            print("%-8s %5d  %10.3e %10.3e %9.3f  %8.2f %8.2f  %9.2f"
                  % (name, spp, mo, mn, mo / mn, to, tn, (mo * to) / (mn * tn)), flush=True)


if __name__ == "__main__":
    main()
