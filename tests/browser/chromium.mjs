// chromium.mjs -- Debian's Chromium as every browser test starts it:
// headless, in a fresh profile of its own, with nothing of its own on the
// network (no updates, sync or background requests), at the window size
// the test asks for.  When it cannot start, launch() prints the case
// chromium_launch as failed and ends the process, so a missing browser
// never passes.
import { chromium } from "playwright-core";
import { mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";

const ARGS = [
  "--headless",
  "--no-sandbox",
  "--disable-gpu",
  "--disable-background-networking",
  "--disable-component-update",
  "--disable-sync",
  "--no-first-run",
];

// { context, close }: close() ends the browser and removes its profile.
export async function launch(fail, options) {
  const profile = mkdtempSync(join(tmpdir(), "rayd-chromium-"));
  const gone = () => rmSync(profile, { recursive: true, force: true });
  try {
    const context = await chromium.launchPersistentContext(profile, {
      executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
      headless: true,
      args: ARGS,
      deviceScaleFactor: 1,
      acceptDownloads: true,
      ...options,
    });
    const close = async () => {
      await context.close().catch(() => {});
      gone();
    };
    return { context, close };
  } catch (e) {
    gone();
    fail("chromium_launch", e.message);
    process.exit(0);
  }
}
