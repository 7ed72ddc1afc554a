// render.js -- talks to rayd and paints the canvas progressively.
//
// A full render is three things at once:
//   1. POST v1/render of the same scene at a quarter of the size and one
//      sample (the quick pass), drawn scaled over the whole canvas;
//   2. POST v1/scenes, which validates and compiles the scene and gives its
//      id (errors come from here, with their JSON Pointer or line/column);
//   3. the full-resolution tiles, GET v1/scenes/{id}/image.png?x=&y=&w=&h=,
//      a few in flight at a time, centre first, each drawn as it arrives.
//      Tiles are immutable (the server sends a strong ETag and a year of
//      max-age), so rendering the same scene again comes from the cache.  A
//      node that does not hold the scene (behind a balancer) answers 404
//      scene_unknown and the tile is POSTed with the scene instead.
// A path-traced scene of more than one sample goes another way (3'): a
// progressive job, POST v1/jobs?progressive=1, whose passes (1, 2, 4, ...
// samples) are followed on its event stream and each drawn over the whole
// canvas as it completes, so the frame is there, noisy, at once and refines
// in place; each pass's pixels are exactly the plain render of its samples.
// With denoise set, the job is asked for denoised passes (?denoise=1); each
// pass then has its raw image too, and showRaw picks which one is drawn:
// setRaw redraws the pass shown from its other image, without rendering.
// Every request of a render shares one AbortController: a new render aborts
// the old one's fetches, and rayd cancels the work of a client that left.
// The tiles are drawn 1:1 at integer positions from bitmaps decoded with no
// colour conversion, so the finished canvas holds exactly the PNG's pixels.

export class ApiError extends Error {
  constructor(fields) {
    super(fields.message || "request failed");
    Object.assign(this, fields);
  }
}

export const isAbort = (e) => e && (e.name === "AbortError" || e.aborted === true);

export class Api {
  constructor(token) {
    this.token = token; // () => string
  }
  headers(json) {
    const h = {};
    if (json) h["Content-Type"] = "application/json";
    const t = this.token();
    if (t) h.Authorization = "Bearer " + t;
    return h;
  }
  // fetch that turns anything but 2xx into an ApiError with the server's fields
  async call(method, url, { body, signal } = {}) {
    let res;
    try {
      res = await fetch(url, { method, headers: this.headers(body !== undefined), body, signal, cache: "default" });
    } catch (e) {
      if (signal && signal.aborted) throw Object.assign(new Error("aborted"), { name: "AbortError" });
      throw new ApiError({ network: true, message: "cannot reach the server (" + (e.message || e) + ")" });
    }
    if (res.ok) return res;
    let fields = { status: res.status, code: "http_" + res.status, message: res.statusText || "error" };
    try {
      const j = await res.json();
      if (j && j.error) fields = { ...fields, ...j.error };
    } catch (_) {
      /* not JSON: keep the status line */
    }
    fields.retryAfter = Number(res.headers.get("Retry-After")) || 0;
    throw new ApiError(fields);
  }
  async raysTotal(signal) {
    try {
      const res = await fetch("metrics", { headers: this.headers(false), signal, cache: "no-store" });
      if (!res.ok) return null;
      const m = /^rayd_rays_total (\d+(?:\.\d+)?(?:e\+?\d+)?)$/m.exec(await res.text());
      return m ? Number(m[1]) : null;
    } catch (_) {
      return null;
    }
  }
}

// The quick pass: the same scene at a quarter of the size, one sample.
export function lowresText(scene, div = 4) {
  if (!scene || typeof scene !== "object" || Array.isArray(scene)) return null;
  const s = structuredClone(scene);
  const r = s.render === undefined ? {} : s.render;
  if (!r || typeof r !== "object" || Array.isArray(r)) return null;
  const w = r.width === undefined ? 640 : r.width;
  const h = r.height === undefined ? 480 : r.height;
  if (!Number.isInteger(w) || !Number.isInteger(h) || w < 1 || h < 1) return null;
  r.width = Math.max(1, Math.round(w / div));
  r.height = Math.max(1, Math.round(h / div));
  r.samples = 1;
  s.render = r;
  return JSON.stringify(s);
}

// Path-traced with more than one sample: worth refining pass by pass.
export function isProgressive(scene) {
  const r = (scene && scene.render) || {};
  return r.integrator === "path" && Number.isInteger(r.samples) && r.samples > 1;
}

// Whether e is a server's refusal of a progressive job: a cluster node
// (rayd --redis) makes none with an EXR, AOVs or denoised passes, and says
// so as 400 bad_parameter naming `progressive`.  The page then renders such
// scenes as a single node would without it: tile by tile, or as a plain job.
export function progressiveRefused(e) {
  return e instanceof ApiError && e.status === 400 && e.parameter === "progressive";
}

// The events of a Server-Sent Events text, and what is left of it.
export function sseEvents(buf) {
  const events = [];
  let k;
  while ((k = buf.indexOf("\n\n")) >= 0) {
    const ev = {};
    for (const line of buf.slice(0, k).split("\n")) {
      const i = line.indexOf(": ");
      if (i > 0) ev[line.slice(0, i)] = line.slice(i + 2);
    }
    buf = buf.slice(k + 2);
    if (ev.event && ev.data) events.push({ event: ev.event, data: JSON.parse(ev.data) });
  }
  return { events, rest: buf };
}

export function sizeOf(scene) {
  const r = (scene && scene.render) || {};
  const w = r.width === undefined ? 640 : r.width;
  const h = r.height === undefined ? 480 : r.height;
  return Number.isInteger(w) && Number.isInteger(h) && w > 0 && h > 0 && w * h <= 40e6 ? [w, h] : null;
}

// Tiles of the image, the centre first.
export function tileOrder(w, h, size) {
  const tiles = [];
  for (let y = 0; y < h; y += size)
    for (let x = 0; x < w; x += size) tiles.push({ x, y, w: Math.min(size, w - x), h: Math.min(size, h - y) });
  const cx = w / 2,
    cy = h / 2;
  const d = (t) => (t.x + t.w / 2 - cx) ** 2 + (t.y + t.h / 2 - cy) ** 2;
  return tiles.sort((a, b) => d(a) - d(b) || a.y - b.y || a.x - b.x);
}

const sleep = (ms, signal) =>
  new Promise((resolve, reject) => {
    const t = setTimeout(resolve, ms);
    signal.addEventListener("abort", () => {
      clearTimeout(t);
      reject(Object.assign(new Error("aborted"), { name: "AbortError" }));
    });
  });

export class Renderer {
  constructor(canvas, api) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d", { alpha: false });
    this.api = api;
    this.ctrl = null;
    this.concurrency = 4;
    this.denoise = false; // progressive jobs asked denoised
    this.showRaw = false; // a denoised job's passes drawn raw
    this.shown = null; // the pass on the canvas: {url, raw}; raw null unless denoised
    this.drawSeq = 0;
  }

  cancel() {
    if (this.ctrl) this.ctrl.abort();
    this.ctrl = null;
  }

  fresh() {
    this.cancel();
    this.shown = null;
    this.ctrl = new AbortController();
    return this.ctrl;
  }

  setSize(w, h) {
    if (this.canvas.width === w && this.canvas.height === h) return;
    this.canvas.width = w;
    this.canvas.height = h;
    this.ctx.fillStyle = "#0d0f13";
    this.ctx.fillRect(0, 0, w, h);
    if (this.onResize) this.onResize();
  }

  async bitmap(res) {
    const blob = await res.blob();
    return createImageBitmap(blob, { colorSpaceConversion: "none", premultiplyAlpha: "none" });
  }

  // Draws a low-resolution render scaled over the canvas.
  async lowres(text, signal) {
    const res = await this.api.call("POST", "v1/render", { body: text, signal });
    const bmp = await this.bitmap(res);
    if (signal.aborted) return false;
    this.ctx.imageSmoothingEnabled = true;
    this.ctx.imageSmoothingQuality = "medium";
    this.ctx.drawImage(bmp, 0, 0, this.canvas.width, this.canvas.height);
    bmp.close();
    return true;
  }

  // A preview frame while the camera moves: the quick pass only.
  async preview(scene, size) {
    const ctrl = this.fresh();
    const text = lowresText(scene);
    if (!text) throw new ApiError({ message: "render.width/height are not valid" });
    this.setSize(size[0], size[1]);
    await this.lowres(text, ctrl.signal);
  }

  // Draws one pass's image over the whole canvas, 1:1 (unless a later
  // draw began meanwhile: that one is drawn instead).
  async drawPass(url, signal) {
    const mine = ++this.drawSeq;
    let res;
    try {
      res = await this.api.call("GET", url, { signal });
    } catch (e) {
      if (e instanceof ApiError && e.status === 410) return false; // a newer pass is coming
      throw e;
    }
    const bmp = await this.bitmap(res);
    if (signal.aborted) return false;
    if (mine === this.drawSeq) this.ctx.drawImage(bmp, 0, 0);
    bmp.close();
    return true;
  }

  passUrl(p) {
    return this.showRaw && p.raw ? p.raw : p.url;
  }

  // Shows the pass on the canvas raw (or denoised) from now on; true when
  // it was redrawn (a denoised job's pass is shown).
  async setRaw(raw) {
    this.showRaw = raw;
    const p = this.shown;
    if (!p || !p.raw) return false;
    return this.drawPass(this.passUrl(p), new AbortController().signal);
  }

  // A progressive job: each pass drawn as it completes (only the newest of
  // those that arrived together).  progress({phase: "pass", samples,
  // target, done, total, progress, id}) after each; progress is the
  // server's share of the sample work done (a pass of 64 samples weighs
  // 32 times one of 2), not done / total.  The stream is read with fetch,
  // since EventSource cannot send the token.  Aborted (a new render, an
  // orbit, Stop), the job is deleted, so the server stops at once; so it is
  // when the stream breaks or a pass cannot be fetched.  A job that failed
  // or was cancelled is an ApiError with job: true.  The
  // POST that makes the job is not aborted: its answer names the job to
  // delete (rayd answers it as soon as the scene is read).
  async progressive(text, progress, lowDone, signal) {
    const q = "v1/jobs?progressive=1" + (this.denoise ? "&denoise=1" : "");
    const job = await (await this.api.call("POST", q, { body: text })).json();
    const drop = () => this.api.call("DELETE", `v1/jobs/${job.id}`).catch(() => {});
    if (signal.aborted) {
      drop();
      throw Object.assign(new Error("aborted"), { name: "AbortError" });
    }
    signal.addEventListener("abort", drop, { once: true });
    let ended = false; // its done event came: nothing left to delete
    try {
      const res = await this.api.call("GET", `v1/jobs/${job.id}/events`, { signal });
      const reader = res.body.getReader();
      const dec = new TextDecoder();
      let buf = "";
      for (;;) {
        const { value, done } = await reader.read();
        if (done) throw new ApiError({ network: true, message: "the job's event stream ended early" });
        const got = sseEvents(buf + dec.decode(value, { stream: true }));
        buf = got.rest;
        const passes = got.events.filter((e) => e.event === "pass");
        const end = got.events.find((e) => e.event === "done");
        if (passes.length) {
          const p = passes[passes.length - 1].data;
          await lowDone; // passes go over the quick pass, never under it
          const url = p.image_url.replace(/^\//, "");
          const shown = { url, raw: p.raw_url ? p.raw_url.replace(/^\//, "") : null };
          if (signal.aborted) throw Object.assign(new Error("aborted"), { name: "AbortError" });
          this.shown = shown;
          if ((await this.drawPass(this.passUrl(shown), signal)) || end)
            progress({
              phase: "pass",
              samples: p.samples,
              done: p.pass,
              total: p.passes,
              progress: p.progress,
              id: job.scene_id,
              denoised: !!shown.raw,
            });
        }
        ended = !!end;
        if (end && end.data.state === "succeeded") return { id: job.scene_id, samples: end.data.samples };
        if (end)
          throw new ApiError({
            job: true,
            code: "job_" + end.data.state,
            message: end.data.error || "the render was cancelled",
          });
      }
    } catch (e) {
      // the stream broke or a pass could not be had: the job would go on
      // rendering for no one (an abort has deleted it already)
      if (!ended && !signal.aborted) drop();
      throw e;
    } finally {
      signal.removeEventListener("abort", drop);
    }
  }

  // The quick pass, then every tile (or, path-traced, every pass).
  // progress({done, total, phase}) is called as the picture fills in.
  // Resolves with {id, width, height}.
  async full(text, scene, progress) {
    const ctrl = this.fresh();
    const signal = ctrl.signal;
    const size = sizeOf(scene);
    if (size) this.setSize(size[0], size[1]);
    const lowText = size ? lowresText(scene) : null;
    let lowDone = Promise.resolve(false);
    if (lowText)
      lowDone = this.lowres(lowText, signal).then(
        (ok) => {
          if (ok) progress({ phase: "preview" });
          return ok;
        },
        () => false // its error (if any) is the scene's, reported below
      );
    if (size && isProgressive(scene) && !this.noProgressive) {
      try {
        const r = await this.progressive(text, progress, lowDone, signal);
        if (this.ctrl === ctrl) this.ctrl = null;
        return { id: r.id, width: size[0], height: size[1], samples: r.samples };
      } catch (e) {
        if (!progressiveRefused(e)) {
          ctrl.abort(); // the quick pass too
          throw e;
        }
        this.noProgressive = true; // this server's tiles, from now on
      }
    }
    let info;
    try {
      info = await (await this.api.call("POST", "v1/scenes", { body: text, signal })).json();
    } catch (e) {
      ctrl.abort(); // the quick pass too
      throw e;
    }
    if (signal.aborted) throw Object.assign(new Error("aborted"), { name: "AbortError" });
    if (!size || size[0] !== info.width || size[1] !== info.height) this.setSize(info.width, info.height);
    const tsize = info.width * info.height > 1024 * 768 ? 128 : 64;
    const tiles = tileOrder(info.width, info.height, tsize);
    let done = 0,
      next = 0;
    progress({ phase: "tiles", done, total: tiles.length, id: info.id });
    const one = async (t) => {
      const q = `?x=${t.x}&y=${t.y}&w=${t.w}&h=${t.h}`;
      for (let attempt = 0; ; attempt++) {
        try {
          let r;
          try {
            r = await this.api.call("GET", `v1/scenes/${info.id}/image.png${q}`, { signal });
          } catch (e) {
            if (!(e instanceof ApiError) || e.code !== "scene_unknown") throw e;
            r = await this.api.call("POST", "v1/render" + q, { body: text, signal });
          }
          return await this.bitmap(r);
        } catch (e) {
          // a full queue is worth waiting for a little, like a balancer would
          if (e instanceof ApiError && e.status === 503 && attempt < 5)
            await sleep(1000 * (e.retryAfter || 1), signal);
          else throw e;
        }
      }
    };
    const worker = async () => {
      while (next < tiles.length && !signal.aborted) {
        const t = tiles[next++];
        const bmp = await one(t);
        await lowDone; // tiles go over the quick pass, never under it
        if (signal.aborted) return;
        this.ctx.drawImage(bmp, t.x, t.y);
        bmp.close();
        done++;
        progress({ phase: "tiles", done, total: tiles.length, id: info.id });
      }
    };
    try {
      await Promise.all(Array.from({ length: Math.min(this.concurrency, tiles.length) }, worker));
    } catch (e) {
      ctrl.abort(); // the other tiles in flight
      throw e;
    }
    if (signal.aborted) throw Object.assign(new Error("aborted"), { name: "AbortError" });
    if (this.ctrl === ctrl) this.ctrl = null;
    return info;
  }
}
