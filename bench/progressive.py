#!/usr/bin/env python3
"""progressive.py -- time to each pass of a progressive job over HTTP.

    python3 bench/progressive.py URL SCENE.json WIDTHxHEIGHT [RUNS]

POSTs the scene (resized, a fresh seed each run so no cache answers) to
URL/v1/jobs?progressive=1, follows its event stream, and prints for each
run the seconds from the POST to each pass event, then the medians.
`make bench` runs it against a rayd it starts (bench/run.sh).
"""
import http.client
import json
import statistics
import sys
import time
import urllib.parse


def one_run(url, scene):
    u = urllib.parse.urlparse(url)
    body = json.dumps(scene).encode()
    t0 = time.monotonic()
    c = http.client.HTTPConnection(u.hostname, u.port, timeout=600)
    c.request("POST", "/v1/jobs?progressive=1", body, {"Content-Type": "application/json"})
    r = c.getresponse()
    job = json.loads(r.read())
    if r.status != 202:
        sys.exit("POST /v1/jobs answered %d: %s" % (r.status, job))
    c.request("GET", "/v1/jobs/%s/events" % job["id"])
    r = c.getresponse()
    times, event = {}, None
    for raw in r:
        line = raw.decode().rstrip("\n")
        if line.startswith("event: "):
            event = line[7:]
        elif line.startswith("data: ") and event == "pass":
            times[json.loads(line[6:])["samples"]] = time.monotonic() - t0
        elif line.startswith("data: ") and event == "done":
            break
    c.close()
    return times


def main():
    url, path, size = sys.argv[1], sys.argv[2], sys.argv[3]
    runs = int(sys.argv[4]) if len(sys.argv) > 4 else 3
    w, h = (int(x) for x in size.split("x"))
    scene = json.load(open(path))
    scene["render"].update(width=w, height=h)
    all_runs = []
    for k in range(runs):
        scene["render"]["seed"] = 1000 + k
        times = one_run(url, scene)
        all_runs.append(times)
        print("run %d %s: %s" % (k + 1, size, " ".join("%d:%.3f" % kv for kv in sorted(times.items()))))
    samples = sorted(set.intersection(*(set(t) for t in all_runs)))
    med = " | ".join("%.3f" % statistics.median(t[s] for t in all_runs) for s in samples)
    print("| samples | " + " | ".join(str(s) for s in samples) + " |")
    print("| %s over HTTP, s after the POST (median of %d) | %s |" % (size, runs, med))


if __name__ == "__main__":
    main()
