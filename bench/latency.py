#!/usr/bin/env python3
"""bench/latency.py RAYD [RUNS] -- what fair scheduling costs and buys.

Starts its own rayd (--threads 2, result cache off) and measures:
  1. p50/p99 latency of 64x64 tile renders (POST /v1/render?x=&y=&w=64&h=64
     of scenes/paper.json at 1280x720, each tile a new region so none is
     answered from a cache) on an idle server;
  2. the same tiles while a backlog of path-traced bulk jobs runs (three
     Cornell boxes, 480x480, 64 samples, distinct so none is joined);
  3. the bulk jobs' wall time alone and with the tile stream beside them.
The bulk throughput lost to fairness is (with - alone - tiles) / alone,
where `tiles` is the tile stream's own work (its idle-server render time
spread over the workers): what bulk loses beyond the CPU the tiles
themselves need.  RUNS (default 3) repeats 2 and 3; medians printed.
"""
import json
import statistics
import subprocess
import sys
import threading
import time
import urllib.request

RAYD = sys.argv[1]
RUNS = int(sys.argv[2]) if len(sys.argv) > 2 else 3
TILES = 40
WORKERS = 2


def start():
    p = subprocess.Popen([RAYD, "--bind", "127.0.0.1", "--port", "0", "--threads", str(WORKERS),
                          "--result-cache-mb", "0", "--max-backlog", "0"],
                         stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    line = p.stdout.readline().strip()
    return p, line.split(" on ")[1]


def post(url, path, body):
    req = urllib.request.Request(url + path, data=body, method="POST",
                                 headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=600) as r:
        return r.status, r.read()


def get(url, path):
    with urllib.request.urlopen(url + path, timeout=60) as r:
        return json.loads(r.read())


def scene(name, **render):
    s = json.load(open("scenes/%s.json" % name))
    s["render"].update(render)
    return s


def tile_stream(url, body, start):
    """TILES sequential 64x64 tile renders from region index start; latencies."""
    lat = []
    for i in range(start, start + TILES):
        x, y = (i * 64) % 1280, ((i * 64) // 1280 * 64) % 720
        t0 = time.perf_counter()
        post(url, "/v1/render?x=%d&y=%d&w=64&h=64" % (x, y), body)
        lat.append(time.perf_counter() - t0)
    return lat


def bulk(url, tag):
    """Three distinct bulk jobs; returns a function waiting for them (wall s)."""
    ids, t0 = [], time.perf_counter()
    for k in range(3):
        s = scene("cornell", width=320, height=320, samples=32)
        s["render"]["seed"] = tag * 10 + k
        _, b = post(url, "/v1/jobs", json.dumps(s).encode())
        ids.append(json.loads(b)["id"])

    def wait():
        while any(get(url, "/v1/jobs/" + i)["state"] in ("queued", "running") for i in ids):
            time.sleep(0.05)
        return time.perf_counter() - t0
    return wait


def pct(xs, q):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(q * (len(xs) - 1))))]


def main():
    p, url = start()
    try:
        paper = json.dumps(scene("paper", width=1280, height=720)).encode()
        idle = []
        for r in range(RUNS):
            idle += tile_stream(url, paper, r * TILES)
        tiles_work = statistics.median([sum(idle[r * TILES:(r + 1) * TILES]) for r in range(RUNS)])
        loaded, alone, beside = [], [], []
        for r in range(RUNS):
            alone.append(bulk(url, 2 * r + 1)())
            wait = bulk(url, 2 * r + 2)
            time.sleep(0.2)  # the backlog is running
            loaded += tile_stream(url, paper, 1000 + r * TILES)
            beside.append(wait())
        a, b = statistics.median(alone), statistics.median(beside)
        lost = (b - a - tiles_work / WORKERS) / a
        print("%-34s %8s %8s" % ("64x64 tile latency (ms)", "p50", "p99"))
        print("%-34s %8.1f %8.1f" % ("idle server", 1e3 * pct(idle, .5), 1e3 * pct(idle, .99)))
        print("%-34s %8.1f %8.1f" % ("beside 3 path-traced bulk jobs", 1e3 * pct(loaded, .5),
                                     1e3 * pct(loaded, .99)))
        print("bulk jobs alone %.2f s, beside the tiles %.2f s, the tiles' own work %.2f s "
              "(of %d workers): bulk throughput lost to fairness %.1f%%"
              % (a, b, tiles_work, WORKERS, 100 * lost))
    finally:
        p.terminate()
        p.wait()


main()
