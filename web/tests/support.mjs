// Helpers of the browser tests: free ports, the server's processes, waiting with deadlines.

import { spawn } from "node:child_process";
import { createServer } from "node:net";
import { dirname, join } from "node:path";

export const bin = process.env.FUSION_SERVER ?? "target/debug/fusion-server";
/// A program of `tools` (`sim_robots`, `simulate`), built beside the server by `cargo test --workspace`.
export const toolBin = (name) => join(process.env.TOOLS_BIN_DIR ?? dirname(bin), name);
export const browserPath = process.env.CHROMIUM ?? "/usr/bin/chromium";
export const browserArgs = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
  "--disable-background-networking", "--disable-component-update", "--disable-sync"];

export function freePort() {
  return new Promise((resolve, reject) => {
    const s = createServer();
    s.listen(0, "127.0.0.1", () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
    s.on("error", reject);
  });
}

const running = new Set();

/// A fusion-server process (or, with `program`, another); `out` collects its standard output.
export function start(args, name, program = bin) {
  const child = spawn(program, args, { stdio: ["ignore", "pipe", "pipe"], env: { ...process.env, RUST_LOG: "warn,zenoh=error" } });
  const proc = { child, name, out: "", err: "", exited: null };
  child.stdout.on("data", (d) => { proc.out += d; });
  child.stderr.on("data", (d) => { proc.err += d; });
  child.on("exit", (code, signal) => {
    proc.exited = { code, signal };
    running.delete(proc);
  });
  running.add(proc);
  return proc;
}

/// Waits for a line of the process's output matching `re`; its first group.
export async function lineOf(proc, re, timeoutMs = 60_000) {
  const deadline = Date.now() + timeoutMs;
  for (;;) {
    const m = proc.out.match(re);
    if (m) return m[1];
    if (proc.exited) throw new Error(`${proc.name} exited early (${JSON.stringify(proc.exited)}): ${proc.err.slice(-2000)}`);
    if (Date.now() > deadline) throw new Error(`${proc.name} printed no ${re} in ${timeoutMs} ms`);
    await sleep(50);
  }
}

export function sleep(ms) {
  return new Promise((r) => setTimeout(r, ms));
}

/// Polls `f` until it returns something truthy; throws after `timeoutMs`.
export async function until(what, f, timeoutMs = 30_000, everyMs = 50) {
  const deadline = Date.now() + timeoutMs;
  for (;;) {
    const v = await f();
    if (v) return v;
    if (Date.now() > deadline) throw new Error(`timed out after ${timeoutMs} ms waiting for ${what}`);
    await sleep(everyMs);
  }
}

/// Stops a process (SIGTERM, then SIGKILL after a grace time).
export async function stop(proc, graceMs = 5000) {
  if (!proc || proc.exited) return;
  proc.child.kill("SIGTERM");
  const deadline = Date.now() + graceMs;
  while (!proc.exited && Date.now() < deadline) await sleep(50);
  if (!proc.exited) proc.child.kill("SIGKILL");
}

/// Kills whatever is still running (the test's last word, also on failure).
export function killAll() {
  for (const p of running) {
    try {
      p.child.kill("SIGKILL");
    } catch {
      // Already gone.
    }
  }
}

export async function getJson(base, path) {
  const r = await fetch(new URL(path, base));
  if (!r.ok) throw new Error(`GET ${path}: HTTP ${r.status} ${await r.text()}`);
  return r.json();
}

let failures = 0;

export function fail(msg) {
  failures += 1;
  console.error(`FAIL: ${msg}`);
  process.exitCode = 1;
}

export function check(ok, msg) {
  if (ok) console.log(`ok: ${msg}`);
  else fail(msg);
  return ok;
}

export function failed() {
  return failures;
}
