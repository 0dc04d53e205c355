// The coach's page in a real browser against a running demo: the server and four robot
// agents (rendered cameras of a simulated match, the real perception) on loopback, or the
// modelled robots when the agent binary is not built. Checks that the page goes live, lists
// the robots online,
// shows the ball and draws it on the pitch; saves a screenshot.
//
//   FUSION_SERVER=target/debug/fusion-server node web/tests/page.test.mjs
import { spawn } from "node:child_process";
import { createServer } from "node:net";
import { mkdirSync } from "node:fs";
import { chromium } from "playwright-core";

const bin = process.env.FUSION_SERVER ?? "target/debug/fusion-server";
const browserPath = process.env.CHROMIUM ?? "/usr/bin/chromium";

function freePort() {
  return new Promise((resolve, reject) => {
    const s = createServer();
    s.listen(0, "127.0.0.1", () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
    s.on("error", reject);
  });
}

function fail(msg) {
  console.error(`FAIL: ${msg}`);
  process.exitCode = 1;
}

const [httpPort, zenohPort] = [await freePort(), await freePort()];
const demo = spawn(bin, [
  "demo", "--http", `127.0.0.1:${httpPort}`, "--listen", `tcp/127.0.0.1:${zenohPort}`, "--for-s", "90",
], { stdio: ["ignore", "pipe", "inherit"], env: { ...process.env, RUST_LOG: "warn,zenoh=error" } });
let demoOut = "";
const url = await new Promise((resolve, reject) => {
  demo.stdout.on("data", (d) => {
    demoOut += d;
    const m = demoOut.match(/Open (http:\/\/\S+\/)/);
    if (m) resolve(m[1]);
  });
  demo.on("exit", (code) => reject(new Error(`demo exited early (${code})`)));
  setTimeout(() => reject(new Error("demo printed no address")), 60_000);
});

const browser = await chromium.launch({
  executablePath: browserPath,
  args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync"],
});
try {
  const page = await browser.newPage({ viewport: { width: 1200, height: 700 } });
  const errors = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  await page.goto(url);
  await page.waitForFunction(() => document.getElementById("conn").textContent === "live", null, { timeout: 30_000 });
  await page.waitForFunction(
    () => document.querySelectorAll("#robots tr").length === 4 &&
      [...document.querySelectorAll("#robots tr td:nth-child(2)")].every((td) => td.textContent === "yes"),
    null, { timeout: 30_000 });
  await page.waitForFunction(() => !document.getElementById("ball").textContent.startsWith("not seen"), null, { timeout: 60_000 });
  const ball = await page.textContent("#ball");
  if (!/^(tracking|coasting|stopped|lost) at \(/.test(ball)) fail(`ball readout: ${ball}`);
  // The ball is drawn: some pixels of the canvas have the ball's orange.
  const orange = await page.evaluate(() => {
    const c = document.getElementById("pitch");
    const d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
    let n = 0;
    for (let i = 0; i < d.length; i += 4) {
      if (d[i] > 230 && d[i + 1] > 60 && d[i + 1] < 190 && d[i + 2] < 170) n++;
    }
    return n;
  });
  if (orange < 10) fail(`no ball drawn on the pitch (${orange} orange pixels)`);
  // Real agents report their cameras' floor footprints, and the page draws them.
  if (demoOut.includes("robot-agent processes")) {
    await page.waitForFunction(() => Number(document.getElementById("pitch").dataset.footprints) >= 4, null, { timeout: 30_000 })
      .catch(() => fail("no camera footprints drawn"));
  }
  mkdirSync("out", { recursive: true });
  await page.screenshot({ path: "out/web-demo.png" });
  if (errors.length) fail(`page errors: ${errors.join("; ")}`);
  if (!process.exitCode) console.log(`ok: page live, 4 robots online, ball "${ball}", ${orange} ball pixels; screenshot out/web-demo.png`);
} catch (e) {
  fail(e.message);
} finally {
  await browser.close();
  demo.kill("SIGTERM");
}
