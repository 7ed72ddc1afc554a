// jobs_view.mjs URL -- drives the preview's Jobs tab of the rayd at URL (started
// with --test-gate open) in Debian's Chromium and prints one "PASS name" or
// "FAIL name: why" line per case.  Run by jobs_view.sh, which starts the rayds.
//
// Every case talks to the real server, except those named stub_*: the
// frame-range jobs of the job contract (a job's "frames", "eta_s",
// "video_url") are not served by rayd yet, so stub_frames_job answers the
// list, the job, its event stream and its frame PNGs from Playwright
// routes (the PNG bytes
// are a real job's image), stub_busy_backoff answers one list request
// with a 503 and Retry-After, which a real server gives only under load,
// and stub_poll_error_shown refuses the connection of a job's polls.
import { cases } from "./cases.mjs";
import { launch } from "./chromium.mjs";
import { readFileSync } from "node:fs";
import { join } from "node:path";

const URL = process.argv[2];
const TOKEN_URL = process.env.TOKEN_URL;
const TOKEN = process.env.TOKEN;
const SCENES = process.env.SCENES || "scenes";
const { pass, fail, check, failed } = cases("page_opens");
async function gate(tiles) {
  return (await fetch(URL + "/v1/test/gate?tiles=" + tiles, { method: "POST" })).json();
}
async function api(path, init) {
  const res = await fetch(URL + path, init);
  return { status: res.status, json: await res.json() };
}

// A small whitted scene; seed makes each one a job of its own (no cache).
let seed = 1000;
function sceneText({ width = 128, height = 96, bad = false } = {}) {
  const s = JSON.parse(readFileSync(join(SCENES, "whitted.json"), "utf8"));
  s.render.width = width;
  s.render.height = height;
  s.render.samples = 1;
  s.render.seed = ++seed;
  if (bad) s.objects[1].radius = -1;
  return JSON.stringify(s, null, 2);
}
const setText = (page, text) => page.evaluate((t) => window.rayd.editor.set(t), text);
const row = (page, id) => page.locator(`#jobs-list li[data-id="${id}"]`);
const rowState = (page, id) => row(page, id).getAttribute("data-state");
const waitRowState = (page, id, state) =>
  page.waitForFunction(
    ([i, s]) => document.querySelector(`#jobs-list li[data-id="${i}"]`)?.dataset.state === s,
    [id, state],
    { timeout: 60000 }
  );
// The newest job of this client, as the server lists it.
async function newestJob() {
  return (await api("/v1/jobs?limit=1")).json.jobs[0];
}
// Submits the editor's scene from the page; the id of the job made.
async function submit(page, priority = "normal") {
  const before = await newestJob();
  await page.selectOption("#job-priority", priority);
  await page.click("#render-job");
  let job;
  for (let i = 0; i < 600; i++) {
    job = await newestJob();
    if (job && (!before || job.id !== before.id)) break;
    await new Promise((r) => setTimeout(r, 50));
  }
  if (!job || (before && job.id === before.id)) throw new Error("no new job on the server");
  await row(page, job.id).waitFor({ timeout: 30000 });
  return job.id;
}

const { context, close } = await launch(fail, { viewport: { width: 1440, height: 860 } });
const cspViolations = [];
await context.exposeBinding("raydCspViolation", (src, v) => cspViolations.push(v));
await context.addInitScript(() =>
  document.addEventListener("securitypolicyviolation", (e) =>
    window.raydCspViolation(`${e.violatedDirective} blocked ${e.blockedURI || "inline"}`)
  )
);

try {
  const page = context.pages()[0] || (await context.newPage());
  const consoleErrors = [];
  page.on("console", (m) => {
    // the answers the cases ask for (a bad scene, the stand-in's 503) are logged by Chromium too
    if (m.type() === "error" && !/^Failed to load resource: (.* status of (422|503) |net::ERR_CONNECTION_REFUSED)/.test(m.text()))
      consoleErrors.push(`${m.type()}: ${m.text()}`);
  });
  page.on("pageerror", (e) => consoleErrors.push("pageerror: " + e.message));
  const streamed = new Set(); // the jobs whose event stream the page opened
  page.on("request", (r) => {
    const m = /\/v1\/jobs\/([0-9a-f]{32})\/events$/.exec(r.url());
    if (m) streamed.add(m[1]);
  });
  await page.goto(URL + "/", { waitUntil: "load" });
  let opened = false;
  await check("page_opens", async () => {
    await page.waitForFunction(() => document.body.dataset.state === "done", null, { timeout: 60000 });
    opened = true;
  });
  if (!opened) throw new Error("the page did not render its example; the other cases were not run");

  // --- the tabs, by keyboard: arrows move, the panels follow -------------------------------
  await check("tabs_by_keyboard", async () => {
    await page.focus("#tab-editor");
    await page.keyboard.press("ArrowRight");
    const a = await page.evaluate(() => ({
      sel: document.getElementById("tab-jobs").getAttribute("aria-selected"),
      focus: document.activeElement.id,
      jobs: !document.getElementById("jobs-panel").hidden,
      editor: !document.getElementById("editor-panel").hidden,
    }));
    if (a.sel !== "true" || a.focus !== "tab-jobs" || !a.jobs || a.editor) return `after ArrowRight ${JSON.stringify(a)}`;
    await page.keyboard.press("ArrowLeft");
    const b = await page.evaluate(() => !document.getElementById("editor-panel").hidden && document.activeElement.id);
    return b === "tab-editor" || `after ArrowLeft focus ${b}`;
  });

  // --- a job from the editor: listed, held by the gate, then done -------------------------------
  let doneId = null;
  await check("submitted_job_listed", async () => {
    await gate(0);
    await setText(page, sceneText());
    const id = await submit(page, "high");
    const text = await row(page, id).innerText();
    if (!/high/.test(text)) return `row "${text}" does not say high`;
    const s = await rowState(page, id);
    if (s !== "queued" && s !== "running") return `state ${s}`;
    if (!(await page.getAttribute(`li[data-id="${id}"] button.job-cancel`, "aria-label")).includes(id.slice(0, 8)))
      return "the Cancel button's label does not name the job";
    const first = await page.$eval("#jobs-list li", (li) => li.dataset.id);
    if (first !== id) return `first row ${first}, not the new job`;
    doneId = id;
  });
  let pngBytes = null;
  await check("progress_reaches_done_with_thumbnail", async () => {
    if (!doneId) return "no job";
    await page.waitForFunction(
      (i) => /\d+\/\d+ tiles/.test(document.querySelector(`li[data-id="${i}"] .job-ptext`).textContent),
      doneId
    );
    await gate("open");
    await waitRowState(page, doneId, "succeeded");
    const job = (await api(`/v1/jobs/${doneId}`)).json;
    const want = `${job.tiles_total}/${job.tiles_total} tiles`;
    const ok = await page
      .waitForFunction(([i, w]) => document.querySelector(`li[data-id="${i}"] .job-ptext`).textContent === w, [doneId, want])
      .then(() => true, () => false);
    if (!ok) return `progress "${await page.textContent(`li[data-id="${doneId}"] .job-ptext`)}", not "${want}"`;
    if (!streamed.has(doneId)) return "the running job was not followed on its event stream";
    await page.waitForFunction((i) => document.querySelector(`li[data-id="${i}"]`).dataset.thumb === "loaded", doneId);
    const w = await page.$eval(`li[data-id="${doneId}"] .job-thumb img`, (img) => img.naturalWidth);
    if (w !== 128) return `thumbnail naturalWidth ${w}, not 128`;
    pngBytes = Buffer.from(await (await fetch(`${URL}/v1/jobs/${doneId}/image.png`)).arrayBuffer());
  });
  await check("download_png_link", async () => {
    if (!doneId) return "no job";
    const links = await page.$$eval(`li[data-id="${doneId}"] a.job-dl`, (as) => as.map((a) => [a.textContent, a.href]));
    if (links.length !== 1 || links[0][0] !== "PNG") return `links ${JSON.stringify(links)}`;
    if (links[0][1] !== `${URL}/v1/jobs/${doneId}/image.png`) return `href ${links[0][1]}`;
    const [dl] = await Promise.all([page.waitForEvent("download"), page.click(`li[data-id="${doneId}"] a.job-dl`)]);
    const got = readFileSync(await dl.path());
    if (!pngBytes || !got.equals(pngBytes)) return `downloaded ${got.length} bytes, not the job's PNG`;
    return dl.suggestedFilename() === `rayd-${doneId.slice(0, 8)}.png` || `name ${dl.suggestedFilename()}`;
  });
  await check("no_cancel_once_finished", async () => {
    const n = await page.locator(`li[data-id="${doneId}"] button.job-cancel`).count();
    return n === 0 || "a finished job still has Cancel";
  });

  // --- Cancel moves a gated job to canceled ------------------------------------------------
  let canceledId = null;
  await check("cancel_gated_job", async () => {
    await gate(0);
    await page.click("#tab-editor");
    await setText(page, sceneText());
    const id = await submit(page);
    canceledId = id;
    await page.click(`li[data-id="${id}"] button.job-cancel`);
    await waitRowState(page, id, "canceled");
    const server = (await api(`/v1/jobs/${id}`)).json.state;
    await gate("open");
    if (server !== "canceled") return `server says ${server}`;
    return (await page.locator(`li[data-id="${id}"] button.job-cancel`).count()) === 0 || "Cancel still shown";
  });

  // --- behind the editor, the streams close and the polls follow the job ----------------------------
  await check("streams_closed_behind_editor", async () => {
    await gate(0);
    await setText(page, sceneText());
    const id = await submit(page);
    await page.waitForFunction(() => window.rayd.jobs.streams.size === 1);
    if (!streamed.has(id)) return "the job was not followed on its event stream";
    await page.click("#tab-editor");
    await page.waitForFunction(() => window.rayd.jobs.streams.size === 0);
    await gate("open");
    await waitRowState(page, id, "succeeded"); // polled while the editor is shown
    return (await page.isHidden("#jobs-panel")) || "the Jobs panel was shown";
  });

  // --- an EXR job has both downloads ---------------------------------------------------------
  await check("exr_job_downloads", async () => {
    await page.check("#job-exr");
    await setText(page, sceneText());
    const id = await submit(page);
    await page.uncheck("#job-exr");
    await waitRowState(page, id, "succeeded");
    await page.waitForFunction((i) => document.querySelectorAll(`li[data-id="${i}"] a.job-dl`).length === 2, id);
    const links = await page.$$eval(`li[data-id="${id}"] a.job-dl`, (as) => as.map((a) => [a.textContent, a.href]));
    const want = [
      ["PNG", `${URL}/v1/jobs/${id}/image.png`],
      ["EXR", `${URL}/v1/jobs/${id}/image.exr`],
    ];
    return JSON.stringify(links) === JSON.stringify(want) || `links ${JSON.stringify(links)}`;
  });

  // --- paging: more jobs than a page, More until the end ---------------------------------------
  await check("paging_with_more", async () => {
    for (let i = 0; i < 7; i++) {
      const r = await fetch(URL + "/v1/jobs", { method: "POST", headers: { "Content-Type": "application/json" }, body: sceneText({ width: 32, height: 24 }) });
      if (r.status !== 202) return `POST /v1/jobs answered ${r.status}`;
    }
    const all = (await api("/v1/jobs?limit=100")).json.jobs.map((j) => j.id);
    await page.click("#tab-jobs");
    await page.evaluate(() => (window.rayd.jobs.pageSize = 4));
    // the list may hold 4 rows before the refresh's page arrives: wait for
    // the page itself (the row count and the More button set together)
    await page.click("#jobs-refresh");
    const full = await page
      .waitForFunction(
        () => document.querySelectorAll("#jobs-list li").length === 4 && !document.getElementById("jobs-more").hidden,
        null,
        { timeout: 15000 }
      )
      .then(() => true, () => false);
    if (!full) return "no More button after a full page";
    let clicks = 0;
    while (await page.isVisible("#jobs-more")) {
      const n = await page.locator("#jobs-list li").count();
      await page.click("#jobs-more");
      await page.waitForFunction((k) => document.querySelectorAll("#jobs-list li").length > k || document.getElementById("jobs-more").hidden, n);
      if (++clicks > 20) return "More never ends";
    }
    const ids = await page.$$eval("#jobs-list li", (lis) => lis.map((li) => li.dataset.id));
    if (ids.length !== all.length) return `${ids.length} rows, the server lists ${all.length}`;
    return JSON.stringify(ids) === JSON.stringify(all) || "rows not in the server's order (newest first)";
  });

  await check("filter_by_state", async () => {
    await page.selectOption("#jobs-state", "canceled");
    await page.waitForFunction(
      () => [...document.querySelectorAll("#jobs-list li")].every((li) => li.dataset.state === "canceled")
    );
    const want = (await api("/v1/jobs?state=canceled&limit=100")).json.jobs.map((j) => j.id);
    await page.waitForFunction((n) => document.querySelectorAll("#jobs-list li").length === n, want.length);
    const ids = await page.$$eval("#jobs-list li", (lis) => lis.map((li) => li.dataset.id));
    await page.selectOption("#jobs-state", "");
    if (!ids.includes(canceledId)) return "the canceled job is not listed";
    return JSON.stringify(ids) === JSON.stringify(want) || `rows ${ids.length}, server ${want.length}`;
  });

  // --- the server's error, with its message and pointer ---------------------------------------
  await check("server_error_shown", async () => {
    const text = sceneText({ bad: true });
    const server = await api("/v1/jobs", { method: "POST", headers: { "Content-Type": "application/json" }, body: text });
    if (server.status < 400 || server.status > 499) return `the server answered ${server.status} to the bad scene`;
    await setText(page, text);
    await page.click("#render-job");
    await page.waitForSelector("#jobs-error:not([hidden])");
    const msg = await page.textContent("#jobs-error-msg");
    const e = server.json.error;
    const want = `${server.status} ${e.code}: ${e.path}: ${e.message}`;
    const role = await page.getAttribute("#jobs-error", "role");
    await page.click("#jobs-dismiss");
    if (role !== "alert") return `the error box's role is ${role}`;
    return msg === want || `shown "${msg}", server "${want}"`;
  });

  // --- a job the server failed: its row says why, in the server's words ----------------------------
  await check("failed_job_error_in_row", async () => {
    await fetch(URL + "/v1/test/gate?work=1000", { method: "POST" }); // a ray budget the render passes
    await page.click("#tab-editor");
    await setText(page, sceneText());
    let id;
    try {
      id = await submit(page);
      await waitRowState(page, id, "failed");
    } finally {
      await fetch(URL + "/v1/test/gate?work=open", { method: "POST" });
    }
    const e = (await api(`/v1/jobs/${id}`)).json.error;
    if (!e) return "the server did not fail the job";
    await page
      .waitForFunction(([i, w]) => document.querySelector(`li[data-id="${i}"] .job-msg`).textContent === w, [id, `${e.code}: ${e.message}`])
      .catch(() => {});
    const shown = await page.textContent(`li[data-id="${id}"] .job-msg`);
    const links = await page.locator(`li[data-id="${id}"] a.job-dl, li[data-id="${id}"] button.job-cancel`).count();
    if (links) return "a failed job offers a download or Cancel";
    return shown === `${e.code}: ${e.message}` || `row says "${shown}", server "${e.code}: ${e.message}"`;
  });

  // --- stand-in: a 503 with Retry-After pauses the view's requests ---------------------------------
  await check("stub_busy_backoff", async () => {
    await page.click("#tab-jobs");
    const seen = [];
    let first = true;
    await page.route(/\/v1\/jobs\?/, (route) => {
      seen.push(Date.now());
      if (!first) return route.continue();
      first = false;
      return route.fulfill({
        status: 503,
        headers: { "Retry-After": "2", "Content-Type": "application/json" },
        body: JSON.stringify({ error: { code: "queue_full", message: "too many unfinished jobs" } }),
      });
    });
    await page.click("#jobs-refresh");
    await page.waitForSelector("#jobs-error:not([hidden])");
    const msg = await page.textContent("#jobs-error-msg");
    await page.click("#jobs-refresh"); // at once: must wait for Retry-After
    await page.waitForFunction(() => document.getElementById("jobs-error").hidden, null, { timeout: 30000 });
    await page.unroute(/\/v1\/jobs\?/);
    if (msg !== "503 queue_full: too many unfinished jobs (Retry-After: 2 s)") return `shown "${msg}"`;
    if (seen.length !== 2) return `${seen.length} list requests`;
    return seen[1] - seen[0] >= 1900 || `asked again after ${seen[1] - seen[0]} ms, before Retry-After`;
  });

  // --- stand-in: a frame-range job as the job contract describes it ---------------------------------
  await check("stub_frames_job", async () => {
    if (!pngBytes) return "no PNG from an earlier case";
    const id = "f".repeat(32);
    const frames = (done, latest) => ({
      first: 0, last: 9, total: 10, done, running: done < 10 ? 1 : 0, queued: 10 - done - (done < 10 ? 1 : 0),
      failed: 0, latest, url: `/v1/jobs/${id}/frames/{k}.png`,
    });
    const running = { id, state: "running", priority: "low", progress: 0.3, created_at: new Date().toISOString(), frames: frames(3, 2), eta_s: 12.5 };
    const done = { ...running, state: "succeeded", progress: 1, frames: frames(10, 9), eta_s: null, video_url: `/v1/jobs/${id}/video.mp4` };
    let polls = 0;
    const frameAsked = [];
    await page.route(/\/v1\/jobs\?/, (r) =>
      r.fulfill({ status: 200, contentType: "application/json", body: JSON.stringify({ jobs: [running], next_after: null, next_url: null }) })
    );
    // the event stream: one frame event (frame 3), sent once the list's
    // values were checked, then it ends (the polls take over, and answer
    // the job done once the frame event was seen)
    let letEvents, letPolls;
    const eventsMay = new Promise((r) => (letEvents = r));
    const pollsMay = new Promise((r) => (letPolls = r));
    const frameEvent = { k: 3, state: "done", frames_done: 4, frames_total: 10, url: `/v1/jobs/${id}/frames/3.png` };
    await page.route(new RegExp(`/v1/jobs/${id}/events$`), async (r) => {
      await eventsMay;
      return r.fulfill({ status: 200, contentType: "text/event-stream", body: `event: frame\ndata: ${JSON.stringify(frameEvent)}\n\n` });
    });
    await page.route(new RegExp(`/v1/jobs/${id}$`), async (r) => {
      await pollsMay;
      polls++;
      return r.fulfill({ status: 200, contentType: "application/json", body: JSON.stringify(done) });
    });
    await page.route(new RegExp(`/v1/jobs/${id}/frames/(\\d+)\\.png$`), (r) => {
      frameAsked.push(Number(/frames\/(\d+)\.png/.exec(r.request().url())[1]));
      return r.fulfill({ status: 200, contentType: "image/png", body: pngBytes });
    });
    try {
      await page.click("#jobs-refresh");
      await row(page, id).waitFor();
      const first = await page.textContent(`li[data-id="${id}"] .job-ptext`);
      if (first !== "frames 3/10 · eta 12 s") return `progress "${first}"`;
      letEvents();
      await page.waitForFunction(
        (i) => document.querySelector(`li[data-id="${i}"] .job-ptext`).textContent === "frames 4/10 · eta 12 s",
        id
      );
      letPolls();
      await waitRowState(page, id, "succeeded");
      await page.waitForFunction((i) => document.querySelector(`li[data-id="${i}"]`).dataset.thumb === "loaded", id);
      const last = await page.textContent(`li[data-id="${id}"] .job-ptext`);
      if (last !== "frames 10/10") return `progress at the end "${last}"`;
      const links = await page.$$eval(`li[data-id="${id}"] a.job-dl`, (as) => as.map((a) => [a.textContent, a.href]));
      const video = links.find((l) => l[0] === "video");
      if (!video || video[1] !== `${URL}/v1/jobs/${id}/video.mp4`) return `links ${JSON.stringify(links)}`;
      const w = await page.$eval(`li[data-id="${id}"] .job-thumb img`, (img) => img.naturalWidth);
      if (!(w > 0)) return "the frame's thumbnail did not load";
      if (!streamed.has(id) || polls < 1) return `stream ${streamed.has(id)}, ${polls} polls`;
      return (frameAsked.includes(3) && frameAsked.includes(9)) || `frames asked ${frameAsked}, not 3 (the event's) and 9 (the last)`;
    } finally {
      await page.unrouteAll();
      await page.click("#jobs-refresh");
    }
  });

  // --- stand-in: a poll that cannot reach the server is said, and asked again later ---------------
  await check("stub_poll_error_shown", async () => {
    await gate(0);
    await page.click("#tab-editor");
    await setText(page, sceneText());
    // every job's status and event stream refused (the others are finished)
    const refused = /\/v1\/jobs\/[0-9a-f]{32}(\/events)?$/;
    const asked = [];
    await page.route(refused, (r) => {
      asked.push(Date.now());
      return r.abort("connectionrefused");
    });
    const id = await submit(page);
    await page.waitForSelector("#jobs-error:not([hidden])", { timeout: 30000 });
    const title = await page.textContent("#jobs-error-title");
    const msg = await page.textContent("#jobs-error-msg");
    await page.unroute(refused);
    await gate("open");
    await waitRowState(page, id, "succeeded"); // followed again once the server answers
    await page.waitForFunction(() => document.getElementById("jobs-error").hidden);
    if (title !== `Cannot follow job ${id.slice(0, 8)}`) return `title "${title}"`;
    if (!/^cannot reach the server/.test(msg)) return `message "${msg}"`;
    return asked.length >= 1 || "no poll was refused";
  });

  await check("no_console_errors", () => (consoleErrors.length ? consoleErrors.join(" | ") : true));
  await check("no_csp_violations", () => (cspViolations.length ? cspViolations.join(" | ") : true));

  // --- with a token: the thumbnail and the download carry it ---------------------------------
  await check("token_thumbnail_and_download", async () => {
    const p = await context.newPage();
    await p.goto(TOKEN_URL + "/", { waitUntil: "load" });
    await p.fill("#token", TOKEN);
    await p.dispatchEvent("#token", "change");
    await p.evaluate((t) => window.rayd.editor.set(t), sceneText({ width: 64, height: 48 }));
    await p.click("#render-job");
    await p.waitForSelector("#jobs-list li[data-state=succeeded][data-thumb=loaded]", { timeout: 60000 });
    const w = await p.$eval("#jobs-list li .job-thumb img", (img) => img.naturalWidth);
    if (w !== 64) return `thumbnail naturalWidth ${w}`;
    const [dl] = await Promise.all([p.waitForEvent("download"), p.click("#jobs-list li a.job-dl")]);
    const got = readFileSync(await dl.path());
    await p.close();
    return got.subarray(1, 4).toString() === "PNG" || `downloaded ${got.length} bytes, not a PNG`;
  });
} catch (e) {
  fail("driver", e.stack || e);
} finally {
  await close();
}
process.exit(0);
