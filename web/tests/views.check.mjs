// The camera views part of the browser test. Live: one robot runs the real agent on the
// simulated match's rendered cameras (`sim_agent`); chosen in the robots' table, its cameras'
// views are drawn with the published ball, a candidate's tip shows under the pointer, its
// perception per camera is listed, at desktop and phone sizes; a robot without cameras says
// so. Replay: the log the live server recorded, served as if live; the chosen robot's view
// follows the replay clock, and after a seek back none is newer than the clock.

import { check, fail, freePort, lineOf, sleep, start, stop, until } from "./support.mjs";

const NS = 1e9;
/// The agent renders and detects on a 2-core machine: its first ball can take a while.
const FIRST_BALL_MS = 90_000;

const tb = (page) => page.evaluate(() => window.__teamBall);

/// The chosen robot's cameras as drawn: [camera, drawn] for each one drawn with its image.
function drawnViews(snap, robot) {
  return ["left", "right"]
    .map((cam) => [cam, snap.views && snap.views[`${robot}/${cam}`]])
    .filter(([, d]) => d && d.drawn && d.imgLoaded);
}

/// Waits for a view of `robot` drawn with the published ball; [camera, drawn].
async function ballShown(page, robot, timeoutMs) {
  return until(`a view of ${robot} with its ball drawn`, async () => {
    const found = drawnViews(await tb(page), robot).find(([, d]) => d.ballDrawn);
    return found || null;
  }, timeoutMs, 200);
}

async function selectRow(page, robot) {
  await page.click(`#robots tr[data-robot="${robot}"]`);
  await until(`${robot} chosen`, async () => (await tb(page)).selected === robot, 5000);
}

/// Moves the pointer over a candidate of `outcome` and reads the tip; null when none shows.
async function tipOver(page, robot, outcome) {
  for (let attempt = 0; attempt < 6; attempt++) {
    const snap = await tb(page);
    for (const [cam, d] of drawnViews(snap, robot)) {
      const c = d.circles.find((k) => k.outcome === outcome);
      if (!c) continue;
      const box = await page.locator(`.cam[data-camera="${cam}"] canvas`).boundingBox();
      await page.mouse.move(box.x + c.px, box.y + c.py);
      const tip = await until("the tip", async () => {
        const v = (await tb(page)).views[`${robot}/${cam}`];
        return v && v.tip;
      }, 1000, 50).catch(() => null);
      if (tip && tip.startsWith(outcome === "ball" ? "ball" : outcome)) return { cam, tip, circle: c };
    }
    await sleep(300);
  }
  return null;
}

async function noOverflow(page) {
  return page.evaluate(() => document.documentElement.scrollWidth <= window.innerWidth);
}

/// On the live page: a robot without cameras, then `agent`'s views at 1440 and 390 px.
/// Returns the stamps (ns) of views seen with the ball, for the replay to go back to.
export async function liveViewChecks(page, agent, plain, shots) {
  await page.setViewportSize({ width: 1440, height: 900 });
  await selectRow(page, plain);
  await until(`the page to say ${plain} has no cameras`, async () => {
    const [snap, health] = [await tb(page), await page.textContent("#sight-health-note")];
    return /^No camera views from /.test(snap.sightNote || "") && health.includes("no camera counters") && [snap.sightNote, health];
  }, 10_000)
    .then(([a, b]) => check(true, `${plain} (modelled, no cameras) chosen: "${a}" / "${b}"`))
    .catch(() => fail(`the page does not say plainly that ${plain} has no camera views or counters`));

  const t0 = Date.now();
  await selectRow(page, agent);
  check(await page.getAttribute(`#robots tr[data-robot="${agent}"]`, "aria-selected") === "true", `robot table: ${agent}'s row marked chosen`);
  const first = await until(`a view of ${agent}`, async () => drawnViews(await tb(page), agent)[0], 30_000, 200)
    .catch(() => null);
  check(first, first
    ? `${agent}: its ${first[0]} camera's view drawn ${((Date.now() - t0) / 1000).toFixed(1)} s after the click (${first[1].width_px}×${first[1].height_px} px, ${first[1].candidates} candidates, ${first[1].age_s.toFixed(2)} s old)`
    : `no camera view of ${agent} drawn`);
  const [cam, d] = await ballShown(page, agent, FIRST_BALL_MS).catch(() => [null, null]);
  if (!check(d, d
    ? `${agent}: the ${cam} camera's view with the published ball drawn ${((Date.now() - t0) / 1000).toFixed(1)} s after the click (seq ${d.seq}, ${d.candidates} candidates, ${d.circles.filter((c) => c.outcome === "rejected").length} rejected)`
    : `no view of ${agent} with the ball drawn within ${FIRST_BALL_MS / 1000} s`)) return [];
  const ballStamps = [d.stamp];

  const [field, sight] = [await page.locator("#field").boundingBox(), await page.locator("#sight").boundingBox()];
  check(sight.x >= field.x + field.width - 1 && sight.y < field.y + field.height,
    `desktop (1440 px): the cameras beside the pitch (at x ${sight.x.toFixed(0)} px, the pitch ends at ${(field.x + field.width).toFixed(0)} px)`);
  const health = await until("the perception table", async () => {
    const rows = await page.$$eval("#sight-health tbody tr", (trs) => trs.map((tr) => [...tr.children].map((td) => td.textContent)));
    return rows.length === 2 && rows.every((r) => Number(r[1]) > 0 && /ms$/.test(r[4])) && rows;
  }, 10_000).catch(() => null);
  check(health, `perception of ${agent} per camera: ${health ? health.map((r) => `${r[0]} ${r[1]} frames/s, ${r[2]} cand./frame, ${r[3]} balls/s, ${r[4]}`).join("; ") : "missing"}`);
  const rejections = await page.$$eval("#sight-rejections li", (lis) => lis.map((li) => li.textContent));
  check(rejections.length === 2, `rejections by reason: ${rejections.join(" | ")}`);

  // The pitch and the cameras in one screen: the pointer over a candidate shows its tip.
  await page.evaluate(() => window.scrollTo(0, 0));
  const rejectedTip = await tipOver(page, agent, "rejected");
  if (rejectedTip) check(/^rejected: [a-z_]+ · score \d\.\d\d/.test(rejectedTip.tip), `pointer on a rejected candidate: "${rejectedTip.tip}"`);
  else console.log("(no rejected candidate in the views drawn to point at)");
  const ballTip = await tipOver(page, agent, "ball");
  check(ballTip, ballTip ? `pointer on the ball's circle: "${ballTip.tip}"` : "no tip over the ball's circle");
  await page.screenshot({ path: `${shots}/cameras.png` });
  await page.mouse.move(1, 1);

  await page.setViewportSize({ width: 390, height: 844 });
  await sleep(300);
  const [pcam, pd] = await ballShown(page, agent, 30_000).catch(() => [null, null]);
  await page.screenshot({ path: `${shots}/cameras-phone.png`, fullPage: true });
  const [f2, s2] = [await page.locator("#field").boundingBox(), await page.locator("#sight").boundingBox()];
  const canvasW = pd ? pd.width_px : 0;
  check(pd && s2.y >= f2.y + f2.height - 1 && canvasW <= 390 && await noOverflow(page),
    `phone (390 px): the cameras below the pitch, the ${pcam} view ${canvasW} px wide with the ball drawn, nothing wider than the screen`);
  if (pd) ballStamps.push(pd.stamp);
  await page.setViewportSize({ width: 1280, height: 800 });
  return ballStamps;
}

/// The recorded log served as if live: `agent` chosen, its view at the replay clock.
export async function replayViewChecks(browser, files, agent, ballStamps, shots) {
  const zenohPort = await freePort();
  const player = start(["replay", "--realtime", "--stay", "--http", "127.0.0.1:0", "--listen",
    `tcp/127.0.0.1:${zenohPort}`, ...files], "recorded replay");
  const url = await lineOf(player, /^(http:\/\/\S+\/)$/m);
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const errors = [];
  page.on("console", (m) => { if (m.type() === "error") errors.push(`console: ${m.text()}`); });
  page.on("pageerror", (e) => errors.push(`page error: ${e}`));
  page.on("response", (r) => { if (r.status() >= 400) errors.push(`HTTP ${r.status()} for ${r.url()}`); });
  const clockNs = (r) => r.start + r.t_s * NS;
  const seek = async (t_s) => {
    // As the range input writes it (14, not 14.0): playwright compares.
    await page.locator("#replay-seek").fill(String(Number(t_s.toFixed(1))));
    return until(`the replay at ${t_s.toFixed(1)} s`, async () => {
      const r = (await tb(page)).replay;
      return r && r.t_s >= t_s - 0.05 && r.t_s < t_s + 2 && r;
    }, 10_000);
  };
  try {
    await page.goto(url);
    await page.waitForFunction(() => window.__teamBall && window.__teamBall.replay, null, { timeout: 30_000 });
    await until(`${agent} in the robots' table`, async () => page.isVisible(`#robots tr[data-robot="${agent}"]`), 20_000);
    await selectRow(page, agent);
    const r0 = (await tb(page)).replay;
    const tBall = Math.max(0, (ballStamps[0] - r0.start) / NS + 0.2);
    const tLate = Math.min(r0.duration_s - 0.3, Math.max(tBall + 3, (ballStamps[ballStamps.length - 1] - r0.start) / NS + 0.2));
    check(tLate >= tBall + 2, `the recorded log (${r0.duration_s.toFixed(1)} s) holds the views seen live (${tBall.toFixed(1)} s in; later ${tLate.toFixed(1)} s)`);

    // At the time a ball was seen live: that view again, re-sent by the server.
    await seek(tBall);
    const [cam, d] = await ballShown(page, agent, 15_000).catch(() => [null, null]);
    check(d, d ? `replay at ${tBall.toFixed(1)} s: ${agent}'s ${cam} view drawn with the ball (${d.age_s.toFixed(2)} s old)` : `replay: no view of ${agent} with its ball drawn`);
    const seq0 = d ? d.seq : 0;
    const next = await until("the next view in the replay", async () => {
      const v = drawnViews(await tb(page), agent).find(([c]) => c === cam);
      return v && v[1].seq > seq0 && v[1];
    }, 5000, 100).catch(() => null);
    check(next, next ? `replay: the view follows the clock (seq ${seq0} then ${next.seq})` : "replay: the view did not change while playing");
    await page.screenshot({ path: `${shots}/cameras-replay.png` });

    // Later, then back: nothing newer than the clock.
    const late = await seek(tLate);
    await until("a view from the later time", async () => drawnViews(await tb(page), agent)
      .some(([, v]) => v.stamp >= clockNs(late) - 2 * NS), 10_000, 100)
      .then(() => check(true, `replay: seek to ${tLate.toFixed(1)} s, the view moved on with it`))
      .catch(() => fail("replay: no view from the later time after a seek forward"));
    await page.click("#replay-toggle");
    await until("paused", async () => (await tb(page)).replay.paused, 5000);
    const back = await seek(tBall);
    const shown = await until("the re-sent view after seeking back", async () => {
      const s = await tb(page);
      const drawn = drawnViews(s, agent);
      return drawn.length && drawn.every(([, v]) => v.stamp <= clockNs(s.replay) + 0.05 * NS) && { drawn, clock: clockNs(s.replay) };
    }, 10_000, 100).catch(() => null);
    const newest = shown && Math.max(...shown.drawn.map(([, v]) => v.stamp));
    check(shown, shown
      ? `replay: after seeking back to ${back.t_s.toFixed(1)} s the view drawn is ${((shown.clock - newest) / NS).toFixed(2)} s older than the clock, none newer`
      : "replay: after seeking back no view, or one newer than the replay clock");
    // Held still for a moment: no view from the future comes back.
    await sleep(1000);
    const after = await tb(page);
    const future = Object.entries(after.views).filter(([, v]) => v.stamp > clockNs(after.replay) + 0.05 * NS);
    check(future.length === 0, `replay: a second later still no view newer than the clock${future.length ? `: ${future.map(([k]) => k).join(", ")}` : ""}`);
    // To the log's start, before most (or all) views: whatever the server has none to re-send
    // for is dropped by the page itself.
    await seek(0);
    const start = await until("no view newer than the start", async () => {
      const s = await tb(page);
      return s.replay.t_s < 0.5 && Object.values(s.views).every((v) => v.stamp <= clockNs(s.replay) + 0.05 * NS) && s;
    }, 5000, 100).catch(() => null);
    check(start, start
      ? `replay: back at the start, ${Object.keys(start.views).length} view(s) kept, none newer than the clock${start.sightNote ? `; "${start.sightNote}"` : ""}`
      : "replay: back at the start, the page still shows views from later");
    const forgot = await page.evaluate(async () => {
      const { ViewStream } = await import("/views.js");
      const s = new ViewStream();
      s.add({ robot_id: "a", camera: "left", candidates: [], stamp: 10 });
      s.add({ robot_id: "a", camera: "right", candidates: [], stamp: 20 });
      s.forgetAfter(15);
      return Object.keys(s.summary()).join(",");
    });
    check(forgot === "a/left", `the page's view store forgets views after a time: kept "${forgot}"`);
    check(errors.length === 0, `no console errors on the recorded replay${errors.length ? `: ${errors.join("; ")}` : ""}`);
  } finally {
    await page.close();
    await stop(player);
  }
}
