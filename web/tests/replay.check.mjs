// The replay part of the browser test: a simulated match log served as if live
// (`replay --realtime --stay`); the page's timeline seeks, its clock follows, pause and speed
// work, and the server's /api/replay agrees.

import { execFileSync } from "node:child_process";
import { check, toolBin, fail, freePort, getJson, lineOf, sleep, start, stop, until } from "./support.mjs";

const MATCH_S = 40;

const tb = (page) => page.evaluate(() => window.__teamBall);

export async function replayChecks(browser, workDir, shots) {
  const out = execFileSync(toolBin("simulate"), ["--scenario", "match", "--seed", "4", "--duration-s", String(MATCH_S),
    "--team-size", "5", "--out", workDir], { encoding: "utf8", timeout: 120_000 });
  const file = out.trim().split("\n").find((l) => l.endsWith(".mcap"));
  if (!file) throw new Error(`simulate wrote no log: ${out}`);
  const zenohPort = await freePort();
  const player = start(["replay", "--realtime", "--stay", "--http", "127.0.0.1:0", "--listen",
    `tcp/127.0.0.1:${zenohPort}`, file], "replay");
  const url = await lineOf(player, /^(http:\/\/\S+\/)$/m);
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const errors = [];
  page.on("console", (m) => { if (m.type() === "error") errors.push(`console: ${m.text()}`); });
  page.on("pageerror", (e) => errors.push(`page error: ${e}`));
  page.on("response", (r) => { if (r.status() >= 400) errors.push(`HTTP ${r.status()} for ${r.url()}`); });
  try {
    await page.goto(url);
    await page.waitForFunction(() => window.__teamBall && window.__teamBall.replay, null, { timeout: 30_000 });
    check(await page.isVisible("#replay-seek"), "replay bar shown with a timeline");
    const s0 = (await tb(page)).replay;
    check(Math.abs(s0.duration_s - MATCH_S) < 1, `timeline spans the log (${s0.duration_s.toFixed(1)} s)`);

    // Seek on the timeline: the server's clock and the page's clock follow.
    await page.locator("#replay-seek").fill("25");
    const at = await until("the replay at 25 s", async () => {
      const r = (await tb(page)).replay;
      return r && r.t_s >= 25 && r.t_s < 27 && r;
    }, 10_000);
    const api = await getJson(url, "/api/replay");
    check(api.t_s >= 25 && api.t_s < 28, `seek to 25 s: the server is at ${api.t_s.toFixed(2)} s`);
    const clock = await until("the clock at 0:25", async () => {
      const text = await page.textContent("#replay-clock");
      return /^0:2[5-7]\.\d \/ 0:40\.\d/.test(text) && text;
    }, 5000).catch(() => null);
    check(clock, `the match clock follows: "${clock ?? (await page.textContent("#replay-clock"))}" (page at ${at.t_s.toFixed(2)} s)`);
    await until("the re-fused ball", async () => (await tb(page)).ball, 10_000)
      .then((b) => check(true, `ball shown after the seek at (${b.x_m.toFixed(2)}, ${b.y_m.toFixed(2)}) m`))
      .catch(() => fail("no ball after seeking"));

    // Pause: the clock stands still. Play on, faster.
    await page.click("#replay-toggle");
    await until("paused", async () => (await tb(page)).replay.paused, 5000);
    const p1 = await page.textContent("#replay-clock");
    await sleep(700);
    const p2 = await page.textContent("#replay-clock");
    check(p1 === p2 && (await getJson(url, "/api/replay")).paused, `paused: the clock stands at "${p2}"`);
    await page.selectOption("#replay-speed", "4");
    await page.click("#replay-toggle");
    const fast = await until("playing at 4x", async () => {
      const r = (await tb(page)).replay;
      return r && !r.paused && r.speed === 4 && r;
    }, 5000);
    const t1 = fast.t_s;
    const w1 = Date.now();
    await sleep(1000);
    const r2 = (await tb(page)).replay;
    const rate = (r2.t_s - t1) / ((Date.now() - w1) / 1000);
    check(rate > 2.5 && rate < 5.5, `playing at 4×: ${rate.toFixed(1)} match seconds per second`);

    // Back in time: the clock goes back, the trail starts afresh.
    await page.locator("#replay-seek").fill("5");
    const back = await until("the replay back at 5 s", async () => {
      const r = (await tb(page)).replay;
      return r && r.t_s >= 5 && r.t_s < 9 && r;
    }, 10_000).catch(() => null);
    check(back, `seek back to 5 s: the page is at ${back ? back.t_s.toFixed(2) : "?"} s`);
    await page.screenshot({ path: `${shots}/replay.png` });
    await page.setViewportSize({ width: 390, height: 844 });
    await sleep(400);
    const bar = await page.locator("#replay").boundingBox();
    check(bar.width <= 390 && await page.isVisible("#replay-seek"), "phone size: the replay bar fits the screen");
    await page.screenshot({ path: `${shots}/replay-phone.png`, fullPage: true });
    check(errors.length === 0, `no console errors on the replay page${errors.length ? `: ${errors.join("; ")}` : ""}`);
  } finally {
    await page.close();
    await stop(player);
  }
}
