// jobs.js -- the Jobs tab: the client's asynchronous jobs, newest first.
//
// The list is GET v1/jobs a page at a time (its next_url behind "More"),
// filtered by state on the server.  Each row shows the job's id, state,
// progress (tiles, a progressive job's passes, or a frame range's frames
// with its eta), priority and age, a thumbnail of its latest image, Cancel
// while it is queued or running, and its downloads.  "Render as job" POSTs
// the editor's scene to v1/jobs and puts the job at the top.
//
// Live updates: while the tab is shown, the two newest unfinished jobs are
// followed on their event streams (read with fetch, since EventSource
// cannot send the token), so
// their tiles, passes and frames show as they finish; the others are
// polled, GET v1/jobs/{id}, a few a tick, each at most about once a second.
// Two streams only: each holds one of the browser's six connections to
// the server, and a page following ten jobs would starve its own tile
// requests.  A stream that breaks leaves its job to the polls.  A finished
// job is asked once more for its final JSON (its image's URL), then never.
// Every request the view makes by itself (polls, pages, thumbnails) goes
// through one Limiter: at most two in flight, and none at all until the
// Retry-After of a 429 or 503 has passed, so a busy server is not hammered.
// The user's own clicks (Cancel, Render as job, a download) go at once.
//
// Thumbnails are fetched with the token (an <img src> could not send it)
// and shown from a blob: URL, only for a row in view (IntersectionObserver)
// and only when the job has an image: a finished job's, a progressive
// job's latest pass, a frame range's latest frame.  Every error is shown
// with the server's message: the view's own in its error box, a row's
// (a failed job, a thumbnail that could not be had) in the row.

import { ApiError, isProgressive, isAbort, progressiveRefused, sseEvents } from "./render.js";

const FINISHED = new Set(["succeeded", "failed", "canceled", "evicted", "gone"]);
const POLL_MS = 1000;
const POLLS_PER_TICK = 4;
const STREAMS = 2;
const rel = (url) => url.replace(/^\//, "");
const short = (id) => id.slice(0, 8);
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// At most n requests in flight; after a 429 or 503, none until Retry-After.
export class Limiter {
  constructor(n) {
    this.n = n;
    this.active = 0;
    this.waiting = [];
    this.pausedUntil = 0;
  }
  pause(seconds) {
    this.pausedUntil = Math.max(this.pausedUntil, Date.now() + 1000 * Math.max(1, seconds || 1));
  }
  async run(fn) {
    for (;;) {
      const wait = this.pausedUntil - Date.now();
      if (wait > 0) await sleep(wait);
      else if (this.active >= this.n) await new Promise((r) => this.waiting.push(r));
      else break;
    }
    this.active++;
    try {
      return await fn();
    } catch (e) {
      if (e instanceof ApiError && (e.status === 429 || e.status === 503)) this.pause(e.retryAfter);
      throw e;
    } finally {
      this.active--;
      const next = this.waiting.shift();
      if (next) next();
    }
  }
}

// "400 bad_scene: /objects/1/radius: must be > 0", with what the server said.
export function errorText(e) {
  if (!(e instanceof ApiError)) return String((e && e.message) || e);
  if (e.network) return e.message;
  let where = "";
  if (e.path) where = `${e.path}: `;
  else if (e.line) where = `line ${e.line}, column ${e.column}: `;
  const wait = e.status === 429 || e.status === 503 ? ` (Retry-After: ${Math.max(1, e.retryAfter || 1)} s)` : "";
  return `${e.status} ${e.code}: ${where}${e.message}${wait}`;
}

export function ageText(s) {
  if (!(s >= 0)) return "";
  if (s < 60) return `${Math.floor(s)} s`;
  if (s < 3600) return `${Math.floor(s / 60)} min`;
  if (s < 86400) return `${Math.floor(s / 3600)} h`;
  return `${Math.floor(s / 86400)} d`;
}

// What a row says of its progress, and the fraction for its bar.
export function progressOf(job) {
  const f = job.frames;
  if (f && typeof f === "object") {
    let text = `frames ${f.done}/${f.total}`;
    if (f.failed) text += ` · ${f.failed} failed`;
    if (typeof job.eta_s === "number" && !FINISHED.has(job.state)) text += ` · eta ${ageText(job.eta_s)}`;
    return { text, frac: f.total ? f.done / f.total : 0 };
  }
  const p = job.passes;
  if (p && typeof p === "object") {
    const text = `pass ${p.done}/${p.total} · ${p.samples}${p.samples_target ? "/" + p.samples_target : ""} spp`;
    return { text, frac: typeof job.progress === "number" ? job.progress : p.total ? p.done / p.total : 0 };
  }
  if (typeof job.tiles_total === "number")
    return { text: `${job.tiles_done}/${job.tiles_total} tiles`, frac: job.progress || 0 };
  return { text: "", frac: 0 };
}

// The URL of the job's latest image, or null while it has none.
export function thumbOf(job) {
  const f = job.frames;
  if (f && typeof f === "object")
    return f.latest !== null && f.latest !== undefined && f.url ? f.url.replace("{k}", String(f.latest)) : null;
  if (job.state === "succeeded" && job.image_url) return job.image_url;
  if (job.passes && job.passes.image_url && job.state !== "evicted") return job.passes.image_url;
  return null;
}

// The downloads of a job: [{label, url, name}].
export function downloadsOf(job) {
  const out = [];
  const base = `rayd-${short(job.id)}`;
  const f = job.frames;
  if (job.state === "succeeded" && job.image_url) out.push({ label: "PNG", url: job.image_url, name: base + ".png" });
  if (job.state === "succeeded" && job.exr_url) out.push({ label: "EXR", url: job.exr_url, name: base + ".exr" });
  if (f && typeof f === "object" && f.latest !== null && f.latest !== undefined && f.url)
    out.push({ label: `frame ${f.latest}`, url: f.url.replace("{k}", String(f.latest)), name: `${base}-${f.latest}.png` });
  if (job.video_url) {
    const ext = (/\.(\w+)(\?|$)/.exec(job.video_url) || [0, "mp4"])[1];
    out.push({ label: "video", url: job.video_url, name: `${base}.${ext}` });
  }
  return out;
}

function el(tag, cls, text) {
  const e = document.createElement(tag);
  if (cls) e.className = cls;
  if (text !== undefined) e.textContent = text;
  return e;
}

export class JobsView {
  // opts: text() the editor's text, scene() its parsed value or null,
  // show() selects the Jobs tab.
  constructor(api, opts) {
    this.api = api;
    this.opts = opts;
    this.limiter = new Limiter(2);
    this.pageSize = 20;
    this.filter = "";
    this.rows = new Map(); // id -> {job, li, ..., polledAt, thumb: {want, have, loading, visible}}
    this.next = null;
    this.gen = 0;
    this.ticks = 0;
    this.pollFails = 0;
    this.pollWait = 0;
    this.streams = new Map(); // id -> AbortController of its event stream
    this.$ = (id) => document.getElementById(id);
    this.list = this.$("jobs-list");
    this.observer = new IntersectionObserver((es) => this.seen(es), { root: this.list, rootMargin: "100px" });
    this.$("jobs-state").addEventListener("change", (e) => {
      this.filter = e.target.value;
      this.load();
    });
    this.$("jobs-refresh").addEventListener("click", () => this.load());
    this.$("jobs-more").addEventListener("click", () => this.more());
    this.$("jobs-dismiss").addEventListener("click", () => this.clearError());
    this.$("render-job").addEventListener("click", () => this.submit());
    this.list.addEventListener("click", (e) => this.clicked(e));
    setInterval(() => this.tick(), POLL_MS);
  }

  // ---- errors: shown until dismissed or until what failed works again ----
  error(title, e, source = "user") {
    this.errorSource = source;
    this.$("jobs-error-title").textContent = title;
    this.$("jobs-error-msg").textContent = errorText(e);
    this.$("jobs-error").hidden = false;
  }
  clearError(source) {
    if (source && this.errorSource !== source) return;
    this.$("jobs-error").hidden = true;
  }
  note(text) {
    this.$("jobs-note").textContent = text;
  }

  // ---- the list: a first page, then More ----
  async load() {
    const gen = ++this.gen;
    const q = new URLSearchParams({ limit: String(this.pageSize) });
    if (this.filter) q.set("state", this.filter);
    await this.page("v1/jobs?" + q, gen, true);
  }
  async more() {
    if (this.next) await this.page(rel(this.next), this.gen, false);
  }
  async page(url, gen, fresh) {
    const more = this.$("jobs-more");
    more.disabled = true;
    this.note("loading…");
    try {
      const res = await this.limiter.run(() => this.api.call("GET", url));
      const j = await res.json();
      if (gen !== this.gen) return;
      if (fresh) this.clear();
      for (const job of j.jobs) if (!this.rows.has(job.id)) this.add(job, false);
      this.next = j.next_url || null;
      this.clearError("list");
    } catch (e) {
      if (gen === this.gen) this.error("Cannot list the jobs", e, "list");
    } finally {
      if (gen === this.gen) {
        more.hidden = !this.next;
        more.disabled = false;
        this.counted();
      }
    }
  }
  counted() {
    const n = this.rows.size;
    this.note(n ? `${n} job${n === 1 ? "" : "s"}${this.next ? " (more on the server)" : ""}` : "no jobs");
    document.body.dataset.jobs = String(n);
  }
  clear() {
    for (const ctrl of this.streams.values()) ctrl.abort();
    for (const row of this.rows.values()) this.drop(row);
    this.rows.clear();
    this.list.replaceChildren();
  }
  drop(row) {
    this.observer.unobserve(row.li);
    if (row.url) URL.revokeObjectURL(row.url);
  }

  // ---- one row ----
  add(job, top) {
    const li = el("li", "job");
    li.dataset.id = job.id;
    const thumb = el("div", "job-thumb");
    const img = el("img");
    img.alt = `latest image of job ${short(job.id)}`;
    img.hidden = true;
    const none = el("span", "dim", "no image");
    thumb.append(img, none);
    const main = el("div", "job-main");
    const line = el("div", "job-line");
    const id = el("code", "job-id", short(job.id));
    id.title = job.id;
    const state = el("span", "job-state");
    const prio = el("span", "job-prio dim");
    const age = el("span", "job-age dim");
    line.append(id, state, prio, age);
    const prog = el("div", "job-progress");
    const bar = el("div", "job-bar");
    bar.setAttribute("role", "progressbar");
    bar.setAttribute("aria-label", `progress of job ${short(job.id)}`);
    bar.setAttribute("aria-valuemin", "0");
    bar.setAttribute("aria-valuemax", "100");
    const fill = el("div");
    bar.append(fill);
    const ptext = el("span", "job-ptext");
    prog.append(bar, ptext);
    const msg = el("div", "job-msg");
    msg.hidden = true;
    main.append(line, prog, msg);
    const actions = el("div", "job-actions");
    li.append(thumb, main, actions);
    const row = { job: null, li, img, none, state, prio, age, fill, bar, ptext, msg, actions, polledAt: 0, seenAt: 0 };
    row.thumb = { want: null, have: null, loading: false, visible: false };
    this.rows.set(job.id, row);
    if (top) this.list.prepend(li);
    else this.list.append(li);
    this.observer.observe(li);
    this.show(row, job);
    return row;
  }

  show(row, job) {
    const was = row.job;
    row.job = job;
    row.seenAt = Date.now();
    row.li.dataset.state = job.state;
    row.state.textContent = job.state;
    row.state.className = `job-state s-${job.state}`;
    row.prio.textContent = job.priority || "";
    const p = progressOf(job);
    row.ptext.textContent = p.text;
    const pct = Math.round(100 * Math.max(0, Math.min(1, job.state === "succeeded" ? 1 : p.frac)));
    row.fill.style.width = `${pct}%`;
    row.bar.setAttribute("aria-valuenow", String(pct));
    const why = (job.error && job.error.message && errorTextOf(job.error)) || job.evicted_reason || job.gone || "";
    row.msg.textContent = why;
    row.msg.hidden = !why;
    this.ageOf(row);
    if (!was || was.state !== job.state || JSON.stringify(downloadsOf(was)) !== JSON.stringify(downloadsOf(job)))
      this.actionsOf(row);
    row.thumb.want = thumbOf(job);
    this.thumb(row);
  }

  ageOf(row) {
    const j = row.job;
    let s = NaN;
    if (j.created_at) s = (Date.now() - Date.parse(j.created_at)) / 1000;
    else if (typeof j.age_s === "number") s = j.age_s + (Date.now() - row.seenAt) / 1000;
    row.age.textContent = s >= 0 ? `${ageText(s)} ago` : "";
  }

  actionsOf(row) {
    const job = row.job;
    const out = [];
    if (job.state === "queued" || job.state === "running") {
      const b = el("button", "ghost job-cancel", "Cancel");
      b.setAttribute("aria-label", `Cancel job ${short(job.id)}`);
      b.dataset.cancel = job.id;
      out.push(b);
    }
    for (const d of downloadsOf(job)) {
      const a = el("a", "job-dl", d.label);
      a.href = rel(d.url);
      a.download = d.name;
      a.setAttribute("aria-label", `Download ${d.label} of job ${short(job.id)}`);
      out.push(a);
    }
    row.actions.replaceChildren(...out);
  }

  // ---- thumbnails: fetched when in view and when the job's image changed ----
  seen(entries) {
    for (const e of entries) {
      const row = this.rows.get(e.target.dataset.id);
      if (!row) continue;
      row.thumb.visible = e.isIntersecting;
      this.thumb(row);
    }
  }
  async thumb(row) {
    const t = row.thumb;
    if (!t.visible || t.loading || !t.want || t.want === t.have) return;
    t.loading = true;
    const want = t.want;
    try {
      const res = await this.limiter.run(() => this.api.call("GET", rel(want)));
      const blob = await res.blob();
      if (this.rows.get(row.job.id) !== row) return;
      if (res.status === 202) return; // no image yet after all: asked again when the job changes
      if (row.url) URL.revokeObjectURL(row.url);
      row.url = URL.createObjectURL(blob);
      row.img.src = row.url;
      row.img.hidden = false;
      row.none.hidden = true;
      row.li.dataset.thumb = "loaded";
      row.img.title = "";
      t.have = want;
    } catch (e) {
      // a pass that is no longer kept is followed by a newer one: the
      // next change asks again; anything else is said in the thumbnail
      t.have = want;
      if (!(e instanceof ApiError && e.code === "pass_gone")) {
        row.none.textContent = e instanceof ApiError && !e.network ? `${e.status}` : "error";
        row.none.title = errorText(e);
        row.none.hidden = false;
        row.li.dataset.thumb = "error";
      }
    } finally {
      t.loading = false;
    }
    this.thumb(row); // the image changed while this one was fetched
  }

  // ---- polling the unfinished jobs ----
  tick() {
    this.ticks++;
    for (const row of this.rows.values()) this.ageOf(row);
    if (document.hidden) return;
    const shown = !this.$("jobs-panel").hidden;
    if (!shown) this.park(); // the editor's renders get every connection back
    if (!shown && this.ticks % 3) return; // behind the editor: polled a third as often
    if (Date.now() < this.pollWait) return; // polls failed: waiting longer each time
    const open = [...this.rows.values()].filter((r) => !FINISHED.has(r.job.state));
    for (const row of open)
      if (shown && this.streams.size < STREAMS && !row.streaming && !row.noStream && Date.now() >= this.limiter.pausedUntil)
        this.follow(row);
    const due = open
      .filter((r) => !r.polling && !r.streaming)
      .sort((a, b) => a.polledAt - b.polledAt)
      .slice(0, POLLS_PER_TICK);
    for (const row of due) this.poll(row);
  }
  async poll(row) {
    row.polling = true;
    row.polledAt = Date.now();
    const id = row.job.id;
    try {
      const res = await this.limiter.run(() => this.api.call("GET", `v1/jobs/${id}`));
      const job = await res.json();
      if (this.rows.get(id) === row) this.show(row, job);
      this.pollFails = 0;
      this.clearError("poll");
    } catch (e) {
      if (e instanceof ApiError && (e.status === 404 || e.status === 410) && this.rows.get(id) === row)
        this.show(row, { ...row.job, state: "gone", gone: errorText(e) });
      else {
        // a server gone or failing is asked again after 2, 4, ... 30 s
        this.pollFails = (this.pollFails || 0) + 1;
        this.pollWait = Date.now() + Math.min(30000, 1000 * 2 ** this.pollFails);
        this.error(`Cannot follow job ${short(id)}`, e, "poll");
      }
    } finally {
      row.polling = false;
      row.polledAt = Date.now();
    }
  }

  // Closes the streams while the editor is shown (the jobs are polled then).
  park() {
    for (const ctrl of this.streams.values()) {
      ctrl.parked = true;
      ctrl.abort();
    }
  }

  // The job's event stream, until its done event (then one poll for the
  // final JSON) or until it breaks (then the polls take over).
  async follow(row) {
    const id = row.job.id;
    const ctrl = new AbortController();
    this.streams.set(id, ctrl);
    row.streaming = true;
    let ended = false;
    try {
      const res = await this.api.call("GET", `v1/jobs/${id}/events`, { signal: ctrl.signal });
      const reader = res.body.getReader();
      const dec = new TextDecoder();
      let buf = "";
      while (!ended) {
        const { value, done } = await reader.read();
        if (done) break;
        const got = sseEvents(buf + dec.decode(value, { stream: true }));
        buf = got.rest;
        if (this.rows.get(id) !== row) break;
        let job = row.job;
        for (const ev of got.events) {
          job = applyEvent(job, ev);
          ended = ended || ev.event === "done";
        }
        this.show(row, job);
      }
    } catch (e) {
      if (e instanceof ApiError && (e.status === 429 || e.status === 503)) this.limiter.pause(e.retryAfter);
      else if (!isAbort(e) && !(e instanceof ApiError && (e.status === 404 || e.status === 410)))
        this.error(`Cannot follow job ${short(id)}`, e, "poll");
    } finally {
      this.streams.delete(id);
      row.streaming = false;
      if (!ended && !ctrl.parked) row.noStream = true; // broken or refused: polled from now on
    }
    if (ended && this.rows.get(id) === row) this.poll(row);
  }

  // ---- the user's actions ----
  async clicked(e) {
    const b = e.target.closest("button[data-cancel]");
    if (b) return this.cancel(b);
    const a = e.target.closest("a.job-dl");
    if (a && this.api.token()) {
      // a navigation cannot carry the token: fetch it, save the bytes
      e.preventDefault();
      try {
        const blob = await (await this.api.call("GET", a.getAttribute("href"))).blob();
        const tmp = el("a");
        tmp.href = URL.createObjectURL(blob);
        tmp.download = a.download;
        document.body.append(tmp);
        tmp.click();
        tmp.remove();
        setTimeout(() => URL.revokeObjectURL(tmp.href), 10000);
      } catch (err) {
        this.error(`Cannot download ${a.textContent}`, err);
      }
    }
  }
  async cancel(button) {
    const id = button.dataset.cancel;
    button.disabled = true;
    try {
      const job = await (await this.api.call("DELETE", `v1/jobs/${id}`)).json();
      const row = this.rows.get(id);
      if (row) this.show(row, job);
      this.clearError("user");
    } catch (e) {
      if (e instanceof ApiError && (e.status === 429 || e.status === 503)) this.limiter.pause(e.retryAfter);
      this.error(`Cannot cancel job ${short(id)}`, e);
      button.disabled = false;
    }
  }
  // POST v1/jobs?q; a server that makes no progressive jobs (a cluster
  // node) gets the job again as a plain one, and no more progressive asks.
  async post(q) {
    try {
      return await (await this.api.call("POST", "v1/jobs?" + q, { body: this.opts.text() })).json();
    } catch (e) {
      if (!progressiveRefused(e) || !q.has("progressive")) throw e;
      this.noProgressive = true;
      q.delete("progressive");
      return (await this.api.call("POST", "v1/jobs?" + q, { body: this.opts.text() })).json();
    }
  }
  async submit() {
    const button = this.$("render-job");
    const q = new URLSearchParams({ priority: this.$("job-priority").value });
    if (this.$("job-exr").checked) q.set("format", "exr");
    if (isProgressive(this.opts.scene()) && !this.noProgressive) q.set("progressive", "1");
    if (this.$("denoise").checked) q.set("denoise", "1"); // the toolbar's denoise box
    button.disabled = true;
    try {
      await this.opts.show(); // the list first, so the new job is not cleared by it
      const got = await this.post(q);
      this.clearError("user");
      if (this.filter) {
        // the new job is queued: the filter would hide it
        this.filter = this.$("jobs-state").value = "";
        await this.load();
      } else if (!this.rows.has(got.id)) {
        const job = { ...got, priority: q.get("priority"), progress: 0, created_at: new Date().toISOString() };
        delete job.image_url; // the POST names where the image will be, not an image
        delete job.exr_url;
        this.add(job, true);
        this.counted();
      }
      const row = this.rows.get(got.id);
      if (row) this.poll(row);
    } catch (e) {
      if (e instanceof ApiError && (e.status === 429 || e.status === 503)) this.limiter.pause(e.retryAfter);
      this.error("Render as job failed", e);
    } finally {
      button.disabled = false;
    }
  }
}

// The job as one event of its stream leaves it (a copy; the polls and the
// final GET fill in what events do not carry).
export function applyEvent(job, { event, data }) {
  const j = { ...job };
  if (event === "state" && data.state) j.state = data.state;
  else if (event === "progress") {
    j.tiles_done = data.done;
    j.tiles_total = data.total;
    j.progress = data.progress;
  } else if (event === "pass") {
    j.passes = { ...(j.passes || {}), done: data.pass, total: data.passes, samples: data.samples, image_url: data.image_url };
    j.progress = data.progress;
  } else if (event === "frame") {
    const f = { ...(j.frames || {}) };
    f.done = data.frames_done;
    f.total = data.frames_total;
    if (data.state === "done") {
      f.latest = data.k;
      if (data.url) f.url = data.url.replace(/\/frames\/\d+\./, "/frames/{k}.");
    } else if (data.state === "failed") f.failed = (f.failed || 0) + 1;
    j.frames = f;
  } else if (event === "done") {
    j.state = data.state;
    if (data.error) j.error = { code: "job_" + data.state, message: data.error };
  }
  return j;
}

// A failed job's error object {code, message, path} as one line.
function errorTextOf(err) {
  return `${err.code || "error"}: ${err.path ? err.path + ": " : ""}${err.message}`;
}

// The left pane's tabs, scene.json and Jobs (WAI-ARIA tabs: the arrow keys,
// Home and End move between them).  onSelect(name) after each change.
export function paneTabs(onSelect) {
  const tabs = [...document.querySelectorAll("[role=tab][data-tab]")];
  const select = (name, focus = false) => {
    for (const t of tabs) {
      const on = t.dataset.tab === name;
      t.setAttribute("aria-selected", String(on));
      t.tabIndex = on ? 0 : -1;
      for (const id of t.dataset.shows.split(" ")) document.getElementById(id).hidden = !on;
      if (on && focus) t.focus();
    }
    document.body.dataset.tab = name;
    return onSelect(name);
  };
  for (const t of tabs) {
    t.addEventListener("click", () => select(t.dataset.tab));
    t.addEventListener("keydown", (e) => {
      const i = tabs.indexOf(t);
      const to = { ArrowRight: i + 1, ArrowLeft: i - 1, Home: 0, End: tabs.length - 1 }[e.key];
      if (to === undefined) return;
      e.preventDefault();
      select(tabs[(to + tabs.length) % tabs.length].dataset.tab, true);
    });
  }
  return { select };
}
