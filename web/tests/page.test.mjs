// The coach's page in a real browser (Debian's Chromium driven by playwright-core).
//
// Live: a server (recording a match log) and ten simulated MiRos in three processes: eight
// modelled, one to kill, and one running the real agent on rendered cameras (its camera
// views: views.check.mjs) on loopback. The ball is drawn where /api/state says and moves; every reporting robot's
// sightings are drawn as ellipses; a click on a robot shows its intercept; the killed robot
// turns grey within a second; a frozen server is marked stale and a restarted one is
// reconnected to; the frame rate is measured; screenshots at desktop and phone sizes.
// Replay: a simulated match log played as if live; the timeline seeks, the clock follows,
// pause and speed work; then the recorded live log, with the agent's camera views at the
// replay clock. No console errors (except while the server is deliberately down).
//
//   FUSION_SERVER=target/debug/fusion-server node web/tests/page.test.mjs
import { mkdirSync, mkdtempSync, readdirSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { chromium } from "playwright-core";
import {
  bin, browserArgs, toolBin, browserPath, check, fail, failed, freePort, getJson, killAll, lineOf, sleep, start, stop, until,
} from "./support.mjs";
import { replayChecks } from "./replay.check.mjs";
import { liveViewChecks, replayViewChecks } from "./views.check.mjs";

const SHOTS = "out/screenshots";
const ROBOTS = 10;
const VICTIM = `miro${ROBOTS}`;
/// The robot that runs the real agent (cameras, views) instead of the modelled observer.
const AGENT = `miro${ROBOTS - 1}`;
const GREY = "#9e9e9e";
const watchdog = setTimeout(() => {
  fail("the browser test took longer than 6 minutes");
  killAll();
  process.exit(1);
}, 360_000);

/// The page's debug snapshot.
const tb = (page) => page.evaluate(() => window.__teamBall);

/// Console errors, page errors and failed requests, unless `expected` is set.
function watchErrors(page, errors, phase) {
  page.on("console", (m) => {
    if (m.type() === "error" && !phase.expectErrors) errors.push(`console: ${m.text()}`);
  });
  page.on("pageerror", (e) => errors.push(`page error: ${e}`));
  page.on("response", (r) => {
    if (r.status() >= 400 && !phase.expectErrors) errors.push(`HTTP ${r.status()} for ${r.url()}`);
  });
}

async function startServer(httpPort, zenohPort, recordDir = null) {
  const server = start(["serve", "--open", "--http", `127.0.0.1:${httpPort}`, "--listen", `tcp/127.0.0.1:${zenohPort}`,
    "--id", "web-test", ...(recordDir ? ["--record", recordDir] : [])], "server");
  const url = await lineOf(server, /^(http:\/\/\S+\/)$/m);
  return { server, url };
}

/// The live checks; the match log the first server recorded (its files, in order) and the
/// stamps of views seen with the ball.
async function liveChecks(browser, recordDir) {
  const [httpPort, zenohPort] = [await freePort(), await freePort()];
  let { server, url } = await startServer(httpPort, zenohPort, recordDir);
  const startNs = (BigInt(Date.now()) * 1_000_000n + 2_000_000_000n).toString();
  // One simulated match for every process: the agent's cameras see the others' ball.
  const matchArgs = ["--connect", `tcp/127.0.0.1:${zenohPort}`, "--scenario", "match",
    "--seed", "2", "--team-size", String(ROBOTS), "--duration-s", "240", "--start-ns", startNs];
  const robotArgs = (only) => [...matchArgs, "--only", only];
  const others = Array.from({ length: ROBOTS - 2 }, (_, i) => `miro${i + 1}`).join(",");
  const team = start(robotArgs(others), "robots", toolBin("sim_robots"));
  const victim = start(robotArgs(VICTIM), VICTIM, toolBin("sim_robots"));
  const agent = start([...matchArgs, "--robot-id", AGENT], AGENT, toolBin("sim_agent"));

  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const errors = [];
  const phase = { expectErrors: false };
  watchErrors(page, errors, phase);
  await page.goto(url);
  await page.waitForFunction(() => window.__teamBall && window.__teamBall.connection === "live", null, { timeout: 30_000 });
  const online = await until(`${ROBOTS} robots online on the page`, async () => {
    const s = await tb(page);
    const on = Object.values(s.robots).filter((r) => r.online).length;
    return on === ROBOTS && s;
  }, 60_000);
  check(Object.keys(online.robots).length === ROBOTS, `${ROBOTS} robots drawn online`);

  // The ball is drawn where the server says, and it moves.
  await until("a ball on the page", async () => (await tb(page)).ball, 60_000);
  const [snap, state] = await Promise.all([tb(page), getJson(url, "/api/state")]);
  const dx = Math.hypot(snap.ball.x_m - state.ball.position_m[0], snap.ball.y_m - state.ball.position_m[1]);
  check(dx < 0.25, `ball drawn ${dx.toFixed(3)} m from /api/state's position`);
  const w = snap.canvas.width_px;
  const scale = (w - 32) / state.pitch.length_m;
  const pxErr = Math.hypot(snap.ball.px - (w / 2 + snap.ball.x_m * scale),
    snap.ball.py - (snap.canvas.height_px / 2 - snap.ball.y_m * scale));
  check(pxErr < 1, `ball marker at its field position on the canvas (${pxErr.toFixed(2)} px off)`);
  // The predicted path is drawn as a band that widens with the server's uncertainty.
  const banded = await until("the path's uncertainty band", async () => {
    const b = (await tb(page)).ball;
    return b && b.path_band && b.path_band.ellipses >= 2 && b.path_band.widest_m > b.path_band.first_m && b.path_band;
  }, 30_000, 100).catch((e) => fail(e.message));
  if (banded) {
    check(true, `path band of ${banded.ellipses} ellipses, 2σ from ${(banded.first_m * 100).toFixed(1)} to ${(banded.widest_m * 100).toFixed(1)} cm`);
  }
  const first = snap.ball;
  const moved = await until("the ball to move", async () => {
    const b = (await tb(page)).ball;
    const d = b && Math.hypot(b.x_m - first.x_m, b.y_m - first.y_m);
    return d > 0.1 && d;
  }, 30_000, 100).catch((e) => fail(e.message));
  if (moved) check(true, `ball marker moved ${moved.toFixed(2)} m`);

  // A page opened now shows the ball's past at once: its charts and trail come from
  // /api/history, not only from the states that arrive after it opened.
  {
    const fresh = await browser.newPage({ viewport: { width: 1280, height: 800 } });
    watchErrors(fresh, errors, phase);
    const opened = Date.now();
    await fresh.goto(url);
    const filled = await until("a fresh page's history", async () => {
      const s = await tb(fresh);
      return s && s.historyLoaded >= 10 && s;
    }, 5000).catch(() => null);
    const after_s = (Date.now() - opened) / 1000;
    check(filled && filled.history >= 10,
      `a page opened mid-match has ${filled ? filled.historyLoaded : 0} past samples of the ball in its charts ${after_s.toFixed(1)} s after opening`);
    await fresh.close();
  }

  // One ellipse (at least) per robot reporting sightings.
  const api = await getJson(url, "/api/state");
  const counts = {};
  for (const o of api.observations) if (o.accepted) counts[o.robot_id] = (counts[o.robot_id] || 0) + 1;
  const reporting = Object.keys(counts).filter((id) => counts[id] >= 3);
  const seen = new Set();
  await until("an ellipse per reporting robot", async () => {
    for (const id of Object.keys((await tb(page)).ellipses)) seen.add(id);
    return reporting.every((id) => seen.has(id));
  }, 3000).catch(() => {});
  check(reporting.length > 0 && reporting.every((id) => seen.has(id)),
    `observation ellipses for every reporting robot (${reporting.join(", ")}; drawn for ${[...seen].sort().join(", ")})`);

  // The panel: a row per robot with its rate, trust, latency and outliers; rejections by reason.
  // What the last look saw, for the failure's message.
  let panelSeen = "";
  await until("the panel's robots and rejections", async () => {
    const [rows, reasons, apiNow] = await Promise.all([
      page.$$eval("#robots tr", (trs) => trs.map((tr) => [...tr.children].map((td) => td.textContent))),
      page.$$eval("#rejected li[data-reason]", (lis) => lis.map((li) => li.dataset.reason)),
      getJson(url, "/api/state"),
    ]);
    const server = Object.keys(apiNow.rejected).sort();
    const same = JSON.stringify(reasons.sort()) === JSON.stringify(server);
    // A robot the server has no latency or clock estimate for yet (none of its sightings
    // accepted so far) shows a dash there; every other shows the server's figures.
    const known = new Map(apiNow.robots.map((r) => [r.robot_id, r]));
    const inForm = (r) => {
      const s = known.get(r[0]);
      if (!s || r.length !== 7) return false;
      const latency = s.latency_s == null ? r[4] === "–" : /ms$/.test(r[4]);
      const clock = s.clock_offset_s == null ? /^–( ✓)?$/.test(r[6]) : /^[+-]\d+ ms( ✓)?$/.test(r[6]);
      return latency && clock;
    };
    const odd = rows.filter((r) => !inForm(r));
    panelSeen = `${rows.length} rows (want ${ROBOTS}); rows not in form: ${JSON.stringify(odd)}; ` +
      `rejections on the page [${reasons.join(", ")}], at the server [${server.join(", ")}]`;
    return rows.length === ROBOTS && !odd.length && same;
  }, 10_000)
    .then(() => check(true, "panel: every robot with rate, trust, latency, outliers and clock offset; the rejections by reason as the server counts them"))
    .catch(() => fail(`the panel's robot table or rejection list does not match the server: ${panelSeen}`));

  // The server records a match log: the panel names its file, and no alert is up.
  await until("the recording's line", async () => {
    const [text, alertHidden, st] = await Promise.all([
      page.textContent("#recording"),
      page.$eval("#rec-alert", (e) => e.hidden),
      getJson(url, "/api/state"),
    ]);
    const file = st.recording && st.recording.file && String(st.recording.file).split("/").pop();
    return st.recording && !st.recording.stopped && alertHidden && file && text.includes(file) && text;
  }, 5000)
    .then((text) => check(true, `panel: "${text}"`))
    .catch(() => fail("the panel does not say which file the match log is recorded to"));

  // The ball's wall bounces and inferred kicks, as the server counts them in its state.
  await until("the bounces and kicks in the panel", async () => {
    const [text, st] = await Promise.all([page.textContent("#ball-events"), getJson(url, "/api/state")]);
    const m = st.ball && st.ball.model;
    return m && /^\d+ bounces, \d+ kicks inferred$/.test(text) && text;
  }, 5000)
    .then((text) => check(true, `panel: "${text}"`))
    .catch(async () => fail(`the panel's bounces and kicks: "${await page.textContent("#ball-events")}"`));

  // The frame rate with ten robots, measured in the browser over 5 s.
  const fps = await page.evaluate(() => new Promise((resolve) => {
    let n = 0;
    const t0 = performance.now();
    const step = (t) => {
      n += 1;
      if (t - t0 < 5000) requestAnimationFrame(step);
      else resolve((n - 1) / ((t - t0) / 1000));
    };
    requestAnimationFrame(step);
  }));
  const pageFps = (await tb(page)).drawFps;
  console.log(`frame rate with ${ROBOTS} simulated robots: ${fps.toFixed(1)} frames/s (the page's own count: ${pageFps.toFixed(1)})`);

  // A click on a robot shows where it meets the ball.
  const pick = Object.entries((await tb(page)).robots).find(([, r]) => r.online);
  const box = await page.locator("#pitch").boundingBox();
  await page.mouse.click(box.x + pick[1].px, box.y + pick[1].py);
  const icpt = await until("an intercept on the page", async () => {
    const s = await tb(page);
    return s.intercept && s.intercept.robot_id === pick[0] && s.intercept;
  }, 10_000).catch((e) => fail(e.message));
  if (icpt) {
    // The panel is refreshed a few times a second.
    const text = await until("the intercept in the panel", async () => {
      const t = await page.textContent("#intercept");
      return t.includes(pick[0]) && t.includes("meets the ball") && t;
    }, 3000).catch(async () => page.textContent("#intercept"));
    check(text.includes(pick[0]) && text.includes("meets the ball"),
      `click on ${pick[0]}: intercept in ${icpt.t_s.toFixed(2)} s at (${icpt.point_m.map((v) => v.toFixed(2)).join(", ")}) m, "${text}"`);
    check(typeof icpt.probability === "number" && icpt.probability >= 0 && icpt.probability <= 1 && text.includes("% likely"),
      `the intercept says how likely the ball is within reach (${icpt.probability})`);
  }
  await labelChecks(page);

  mkdirSync(SHOTS, { recursive: true });
  await page.screenshot({ path: `${SHOTS}/desktop.png` });
  // A click off the robots forgets the choice.
  await page.mouse.click(box.x + 3, box.y + 3);
  await until("the choice forgotten", async () => !(await tb(page)).selected, 2000)
    .then(() => check(true, "a click off the robots forgets the intercept"))
    .catch(() => fail("the intercept stayed after a click off the robots"));
  await page.setViewportSize({ width: 390, height: 844 });
  await sleep(500);
  const [field, panel] = [await page.locator("#field").boundingBox(), await page.locator("#panel").boundingBox()];
  check(panel.y >= field.y + field.height - 1 && field.width <= 390,
    `phone size: the panel is below the pitch (pitch ${field.width.toFixed(0)} px wide)`);
  await page.screenshot({ path: `${SHOTS}/phone.png`, fullPage: true });
  // Every robot is named on the pitch, each name whole inside it and over no other label.
  const canvas = await page.locator("#pitch").boundingBox();
  const all = (await tb(page)).labels || [];
  const named = all.filter((l) => l.kind === "robot");
  const clipped = named.filter((l) => l.x < 0 || l.y < 0 || l.x + l.w > canvas.width + 0.5 || l.y + l.h > canvas.height + 0.5);
  const covering = named.filter((l) => all.some((o) => o !== l && o.kind !== "robot" &&
    l.x < o.x + o.w && o.x < l.x + l.w && l.y < o.y + o.h && o.y < l.y + l.h));
  check(named.length > 0 && clipped.length === 0 && covering.length === 0,
    `phone size: ${named.length} robots named, none cut at the pitch's edge (${clipped.map((l) => l.text).join(", ") || "none"}) nor over the stop or intercept label`);
  await page.setViewportSize({ width: 1280, height: 800 });

  // What the agent's cameras see; it stays chosen (its views' stream reconnects below too).
  const ballStamps = await liveViewChecks(page, AGENT, "miro1", SHOTS);

  // A robot killed turns grey within a second.
  const killedAt = Date.now();
  victim.child.kill("SIGKILL");
  const grey = await page.waitForFunction((id) => {
    const r = window.__teamBall.robots[id];
    return r && !r.online && r.colour;
  }, VICTIM, { timeout: 1000, polling: "raf" }).then((h) => h.jsonValue()).catch(() => null);
  const greyMs = Date.now() - killedAt;
  check(grey === GREY, `${VICTIM} killed: drawn grey after ${greyMs} ms (limit 1000 ms)`);
  const row = await page.getAttribute(`#robots tr[data-robot="${VICTIM}"]`, "data-online").catch(() => null);
  await until("the robot table to say offline", async () =>
    (await page.getAttribute(`#robots tr[data-robot="${VICTIM}"]`, "data-online")) === "no", 2000)
    .then(() => check(true, `robot table: ${VICTIM} offline`))
    .catch(() => fail(`robot table still says ${row} for ${VICTIM}`));

  // A server that stops answering is marked stale; a restarted one is reconnected to.
  server.child.kill("SIGSTOP");
  await page.waitForFunction(() => window.__teamBall.connection === "stale", null, { timeout: 5000 })
    .then(() => check(true, "a frozen server: the page says stale"))
    .catch(() => fail("no stale mark while the server was frozen"));
  server.child.kill("SIGCONT");
  await page.waitForFunction(() => window.__teamBall.connection === "live", null, { timeout: 5000 })
    .catch(() => fail("not live again after the server resumed"));
  phase.expectErrors = true;
  await stop(server);
  const log = readdirSync(recordDir).filter((f) => f.endsWith(".mcap")).sort().map((f) => join(recordDir, f));
  await page.waitForFunction(() => window.__teamBall.connection === "down", null, { timeout: 5000 })
    .catch(() => fail("no disconnected mark while the server was down"));
  ({ server } = await startServer(httpPort, zenohPort));
  const before = (await tb(page)).frames;
  await page.waitForFunction((n) => window.__teamBall.connection === "live" && window.__teamBall.frames > n + 5,
    before, { timeout: 15_000 })
    .then(() => check(true, "the page reconnected to the restarted server by itself"))
    .catch(() => fail("the page did not reconnect to the restarted server"));
  await page.waitForFunction(() => window.__teamBall.viewStream === "live", null, { timeout: 10_000 })
    .then(() => check(true, "the camera views' stream reconnected too"))
    .catch(() => fail("the camera views' stream did not reconnect to the restarted server"));
  phase.expectErrors = false;
  await sleep(500);
  check(errors.length === 0, `no console errors on the live page${errors.length ? `: ${errors.join("; ")}` : ""}`);
  await page.close();
  await Promise.all([stop(team), stop(agent), stop(server)]);
  return { fps, log, ballStamps };
}

/// The stop's and the intercept's labels on the pitch cover neither each other nor the ball:
/// as drawn now, and for the worst case (both at the ball) through the page's own layout.
async function labelChecks(page) {
  const s = await tb(page);
  const [stopL, icptL] = ["stop", "intercept"].map((k) => (s.labels || []).find((l) => l.kind === k));
  const ballBox = s.ball && { x: s.ball.px - s.ball.radius_px, y: s.ball.py - s.ball.radius_px, w: 2 * s.ball.radius_px, h: 2 * s.ball.radius_px };
  const hit = (a, b) => a && b && a.x < b.x + b.w && b.x < a.x + a.w && a.y < b.y + b.h && b.y < a.y + a.h;
  check(icptL && !hit(stopL, icptL) && !hit(icptL, ballBox) && !hit(stopL, ballBox),
    `pitch labels apart: "${icptL && icptL.text}"${stopL ? ` and "${stopL.text}"` : ""} cover neither each other nor the ball`);
  const worst = await page.evaluate(async () => {
    const { LabelLayout, overlaps } = await import("/labels.js");
    const layout = new LabelLayout({ x: 0, y: 0, w: 400, h: 300 });
    layout.block({ x: 195, y: 145, w: 10, h: 10 });
    const a = layout.place(200, 150, 60, 13);
    const b = layout.place(200, 150, 70, 13);
    return !overlaps(a, b) && !overlaps(a, { x: 195, y: 145, w: 10, h: 10 }) && !overlaps(b, { x: 195, y: 145, w: 10, h: 10 });
  });
  check(worst, "two labels at one point over the ball are placed apart");
}

const browser = await chromium.launch({ executablePath: browserPath, args: browserArgs });
const workDir = mkdtempSync(join(tmpdir(), "team-ball-web-"));
try {
  console.log(`server binary: ${bin}`);
  const recordDir = join(workDir, "recorded");
  mkdirSync(recordDir);
  const { fps, log, ballStamps } = await liveChecks(browser, recordDir);
  await replayChecks(browser, workDir, SHOTS);
  if (check(log.length > 0 && ballStamps.length > 0, `the live server recorded ${log.length} log file(s)`)) {
    await replayViewChecks(browser, log, AGENT, ballStamps, SHOTS);
  }
  if (!failed()) console.log(`all browser checks passed; ${ROBOTS} robots drawn at ${fps.toFixed(1)} frames/s; screenshots in ${SHOTS}/`);
} catch (e) {
  fail(e.stack || e.message);
} finally {
  clearTimeout(watchdog);
  await browser.close();
  killAll();
  rmSync(workDir, { recursive: true, force: true });
}
