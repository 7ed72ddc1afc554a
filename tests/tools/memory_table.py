#!/usr/bin/env python3
"""memory_table.py -- what four hostile loads make rayd hold, against --max-memory.

Usage: tests/tools/memory_table.py RAYD [MAX_MEMORY]
  RAYD        a rayd binary (build/rayd; or one built from an older commit)
  MAX_MEMORY  passed as --max-memory (e.g. 256M); "-" or absent: not passed
              (an older rayd has no such option)

Each load runs on a fresh rayd on 127.0.0.1 (--port 0), so each peak is its
own (VmHWM of /proc/PID/status), and prints one row of a Markdown table:

  bodies     600 connections each declaring a 4 MiB body and sending all but
             its last 16 bytes (MEM_BODIES=600, MEM_BODY=4194304)
  scenes     4 jobs held queued by the test gate, each a scene of 4 image
             textures of 2048 x 2048 (MEM_SIDE=2048)
  sums       3 concurrent POST /v1/render?format=sums&samples=0-1 of
             2048 x 2048 (MEM_SUMS_SIDE=2048)
  progressive 4 progressive jobs of 2048 x 2048 (2 samples), each left to
             finish a pass, then all DELETEd (MEM_PROG_SIDE=2048)

Columns: answers (status: count; "refused": the connection was reset while
the body was sent, after rayd's early 503), peak resident size (VmHWM),
resident size while held (VmRSS), rayd's own count at its highest (sum of
rayd_memory_bytes, "-" when the build has none), and the resident size and
the count after the load let go (what stays is the scene cache's and the
finished jobs').  Needs python3 only; takes a few minutes and, on a rayd
without a budget, a few GB.
"""
import base64
import json
import os
import re
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "integration", "lib"))
from memory_helpers import png  # noqa: E402  (one PNG maker for the test and this table)
import zlib

RAYD = sys.argv[1] if len(sys.argv) > 1 else "build/rayd"
BUDGET = sys.argv[2] if len(sys.argv) > 2 and sys.argv[2] != "-" else None
N_BODIES = int(os.environ.get("MEM_BODIES", 600))
BODY = int(os.environ.get("MEM_BODY", 4 << 20))
SIDE = int(os.environ.get("MEM_SIDE", 2048))
SUMS_SIDE = int(os.environ.get("MEM_SUMS_SIDE", 2048))
PROG_SIDE = int(os.environ.get("MEM_PROG_SIDE", 2048))
MB = 1 << 20


class Rayd:
    def __init__(self, *args):
        self.err = tempfile.TemporaryFile()
        cmd = [RAYD, "--bind", "127.0.0.1", "--port", "0"] + list(args)
        if BUDGET:
            cmd += ["--max-memory", BUDGET]
        self.p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=self.err, text=True)
        line = self.p.stdout.readline()
        m = re.search(r":(\d+)$", line.strip())
        if not m:
            raise SystemExit("rayd did not start: %r" % line)
        self.port = int(m.group(1))
        self.peak_count = 0
        self.polling = True
        self.poller = threading.Thread(target=self.poll, daemon=True)
        self.poller.start()

    def status(self, key):
        for line in open("/proc/%d/status" % self.p.pid):
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
        return 0

    def counted(self):
        try:
            text = self.get("/metrics")[1].decode()
        except OSError:
            return None
        vals = [float(l.split()[1]) for l in text.splitlines() if l.startswith("rayd_memory_bytes{")]
        return int(sum(vals)) if vals else None

    def poll(self):
        while self.polling:
            c = self.counted()
            if c is None:
                self.peak_count = None
                return
            self.peak_count = max(self.peak_count, c)
            time.sleep(0.05)

    def req(self, method, path, body=None, timeout=600):
        r = urllib.request.Request("http://127.0.0.1:%d%s" % (self.port, path), data=body,
                                   method=method)
        if body is not None:
            r.add_header("Content-Type", "application/json")
        try:
            with urllib.request.urlopen(r, timeout=timeout) as f:
                return f.status, f.read()
        except urllib.error.HTTPError as e:
            return e.code, e.read()

    def get(self, path):
        return self.req("GET", path)

    def stop(self):
        self.polling = False
        self.poller.join()
        self.p.terminate()
        try:
            self.p.wait(60)
        except subprocess.TimeoutExpired:
            self.p.kill()
            self.p.wait()


def scene(w, h, samples, seed, textures=0, side=0):
    mats = {"m": {"color": [0.8, 0.3, 0.2], "diffuse": 0.8}}
    objs = [{"type": "plane", "point": [0, -1, 0], "normal": [0, 1, 0], "material": "m"}]
    for i in range(textures):
        b64 = base64.b64encode(png(side, (i * 37 + seed) % 256)).decode()
        mats["t%d" % i] = {"color": [1, 1, 1], "texture": {"type": "image", "png_base64": b64}}
        objs.append({"type": "sphere", "center": [i - textures / 2.0, 0, -5], "radius": 0.4,
                     "material": "t%d" % i})
    objs.append({"type": "sphere", "center": [0, 0, -4], "radius": 1, "material": "m"})
    return json.dumps({"camera": {"position": [0, 1, 3], "look_at": [0, 0, -5], "up": [0, 1, 0],
                                  "fov_x": 60},
                       "render": {"width": w, "height": h, "samples": samples, "max_depth": 2,
                                  "seed": seed},
                       "materials": mats,
                       "lights": [{"type": "point", "position": [0, 5, 0], "color": [1, 1, 1]}],
                       "objects": objs}).encode()


def answers(codes):
    out = {}
    for c in codes:
        out[c] = out.get(c, 0) + 1
    return ", ".join("%s: %d" % (k, v) for k, v in sorted(out.items(), key=lambda kv: str(kv[0])))


def row(name, r, codes, held_rss, after_rss):
    peak = r.status("VmHWM")
    counted = "-" if r.peak_count is None else "%.0f MB" % (r.peak_count / MB)
    now = r.counted()
    after = "-" if now is None else "%.0f MB" % (now / MB)
    print("| %s | %s | %s | %.0f MB | %.0f MB | %s | %.0f MB | %s |" % (
        name, BUDGET or "none", answers(codes), peak / MB, held_rss / MB, counted, after_rss / MB,
        after), flush=True)


def load_bodies():
    r = Rayd("--max-body", str(BODY), "--timeout", "600", "--upload-seconds", "600")
    socks, codes = [], []
    for _ in range(N_BODIES):
        s = socket.create_connection(("127.0.0.1", r.port), timeout=60)
        try:
            s.sendall(("POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                       "Content-Length: %d\r\n\r\n" % BODY).encode())
            s.sendall(b" " * (BODY - 16))
            s.setblocking(False)
            try:
                got = s.recv(64)
                codes.append(int(got.split()[1]) if got else "closed")
                s.close()
                continue
            except BlockingIOError:
                pass
            socks.append(s)
        except OSError:
            codes.append("refused")
            s.close()
    # an answer may come a moment after the last byte sent
    for s in list(socks):
        try:
            got = s.recv(64)
            codes.append(int(got.split()[1]) if got else "closed")
            socks.remove(s)
        except (BlockingIOError, OSError):
            pass
    codes += ["held"] * len(socks)
    time.sleep(0.5)
    held = r.status("VmRSS")
    for s in socks:
        s.close()
    time.sleep(1)
    r.get("/healthz")
    after = r.status("VmRSS")
    row("%d slow %d MiB bodies" % (N_BODIES, BODY >> 20), r, codes, held, after)
    r.stop()


def load_scenes():
    r = Rayd("--test-gate", "0")
    codes, ids = [], []
    for i in range(4):
        code, body = r.req("POST", "/v1/jobs", scene(32, 32, 1, i + 1, 4, SIDE))
        codes.append(code)
        if code == 202:
            ids.append(json.loads(body)["id"])
    time.sleep(0.3)
    held = r.status("VmRSS")
    for i in ids:
        r.req("DELETE", "/v1/jobs/" + i)
    time.sleep(1)
    r.get("/healthz")
    after = r.status("VmRSS")
    row("4 queued scenes, 4 textures of %d^2 each" % SIDE, r, codes, held, after)
    r.stop()


def load_sums():
    r = Rayd()
    codes = []

    def one(i):
        code, _ = r.req("POST", "/v1/render?format=sums&samples=0-1",
                        scene(SUMS_SIDE, SUMS_SIDE, 1, 100 + i))
        codes.append(code)

    ts = [threading.Thread(target=one, args=(i,)) for i in range(3)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    held = r.status("VmRSS")
    time.sleep(1)
    r.get("/healthz")
    after = r.status("VmRSS")
    row("3 sums answers of %d^2" % SUMS_SIDE, r, codes, held, after)
    r.stop()


def load_progressive():
    r = Rayd()
    codes, ids = [], []
    for i in range(4):
        code, body = r.req("POST", "/v1/jobs?progressive=1",
                           scene(PROG_SIDE, PROG_SIDE, 2, 200 + i))
        codes.append(code)
        if code == 202:
            ids.append(json.loads(body)["id"])
    end = time.time() + 600
    while time.time() < end:  # each accepted job has a pass done (or has ended)
        states = [json.loads(r.get("/v1/jobs/" + i)[1]) for i in ids]
        if all(s.get("passes", {}).get("done", 0) >= 1 or s["state"] != "running" and
               s["state"] != "queued" for s in states):
            break
        time.sleep(0.2)
    held = r.status("VmRSS")
    for i in ids:
        r.req("DELETE", "/v1/jobs/" + i)
    time.sleep(1)
    r.get("/healthz")
    after = r.status("VmRSS")
    row("4 progressive jobs of %d^2, then DELETE" % PROG_SIDE, r, codes, held, after)
    r.stop()


if __name__ == "__main__":
    print("| load | --max-memory | answers | peak RSS | RSS held | rayd's count (peak) | RSS after "
          "| count after |")
    print("|---|---|---|---|---|---|---|---|")
    for f in (load_bodies, load_scenes, load_sums, load_progressive):
        f()
