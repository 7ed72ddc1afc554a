#!/usr/bin/env python3
"""ab.py -- two rayd-render builds on one scene, run alternately, compared by stage.

    python3 bench/ab.py OLD_RAYD_RENDER NEW_RAYD_RENDER SCENE [RUNS [THREADS]]

Runs OLD then NEW, RUNS times (default 9), with --stats, and prints the median
of each stage (parse, decode, build, render, encode, total) for both, and the
median of the per-pair ratios new/old of the whole. Alternating single runs
keeps both builds in the same moments of a shared, noisy machine.
"""
import re
import statistics
import subprocess
import sys

STAGES = ["parse", "decode", "build", "render", "encode", "total"]


def run(binary, scene, threads):
    out = subprocess.run([binary, "--threads", threads, "--stats", scene, "-o", "/dev/null"],
                         capture_output=True, text=True, check=True)
    t = dict(re.findall(r"time (\w+): ([\d.]+)", out.stdout + out.stderr))
    return {k: float(t.get(k, 0)) for k in STAGES}


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    old, new, scene = sys.argv[1:4]
    runs = int(sys.argv[4]) if len(sys.argv) > 4 else 9
    threads = sys.argv[5] if len(sys.argv) > 5 else "2"
    pairs = [(run(old, scene, threads), run(new, scene, threads)) for _ in range(runs)]
    med = lambda side, k: statistics.median(p[side][k] for p in pairs)
    ratio = statistics.median(b["total"] / a["total"] for a, b in pairs)
    print(f"{scene}, {threads} threads, {runs} pairs: "
          + "  ".join(f"{k} {med(0, k):.3f} -> {med(1, k):.3f}" for k in STAGES)
          + f"  | whole new/old {ratio:.2f}")


if __name__ == "__main__":
    main()
