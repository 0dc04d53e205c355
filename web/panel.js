// The side panel: the ball's facts, the robots' table, rejected inputs by reason and the
// server's rate. Rebuilt a few times a second, never on every frame.

import { colourOf, ellipse2Sigma, OFFLINE } from "./pitch.js";

const el = (id) => document.getElementById(id);
const fixed = (v, n, unit = "") => (v == null || !Number.isFinite(v) ? "–" : `${v.toFixed(n)}${unit}`);

function cell(row, text) {
  const td = document.createElement("td");
  td.textContent = text;
  row.appendChild(td);
  return td;
}

export function showBall(b) {
  if (!b) {
    for (const id of ["ball-status", "ball-existence", "ball-pos", "ball-speed", "ball-ellipse", "ball-decel", "ball-restitution", "ball-stop", "ball-contributors"]) {
      el(id).textContent = "–";
    }
    el("ball").textContent = "ball: not seen yet";
    return;
  }
  const speed = Math.hypot(b.velocity_mps[0], b.velocity_mps[1]);
  const e = ellipse2Sigma(b.covariance[0], b.covariance[1], b.covariance[5]);
  const m = b.model;
  const stop = b.prediction && b.prediction.stop;
  el("ball-status").textContent = b.status;
  const existence = typeof b.existence === "number" ? b.existence : 1;
  el("ball-existence").textContent = `${(100 * existence).toFixed(0)} %`;
  el("ball-existence").title = existence < 0.5
    ? "cameras look at this place and do not see the ball: it has most likely been moved"
    : "how likely the ball is where the estimate says";
  el("ball-pos").textContent = `(${b.position_m[0].toFixed(2)}, ${b.position_m[1].toFixed(2)}) m`;
  el("ball-speed").textContent = `${speed.toFixed(2)} m/s`;
  el("ball-ellipse").textContent = e ? `${(100 * e.major_m).toFixed(1)} × ${(100 * e.minor_m).toFixed(1)} cm` : "–";
  el("ball-decel").textContent = `${fixed(m.rolling_decel_mps2, 3, " m/s²")} (${m.decel_samples} samples)`;
  el("ball-restitution").textContent = `${fixed(m.wall_restitution, 2)} (${m.restitution_samples} bounces)`;
  el("ball-stop").textContent = stop
    ? `in ${stop.t_s.toFixed(1)} s at (${stop.position_m[0].toFixed(2)}, ${stop.position_m[1].toFixed(2)}) m`
    : "–";
  el("ball-contributors").textContent = b.contributors.length ? b.contributors.join(", ") : "nobody lately";
  el("ball").textContent = `ball: ${b.status} at (${b.position_m[0].toFixed(2)}, ${b.position_m[1].toFixed(2)}) m, ${speed.toFixed(2)} m/s`;
}

export function showRobots(robots, ids) {
  const body = el("robots");
  const rows = robots.map((r) => {
    const tr = document.createElement("tr");
    tr.dataset.robot = r.robot_id;
    tr.dataset.online = r.online ? "yes" : "no";
    if (!r.online) tr.className = "off";
    const name = cell(tr, r.robot_id);
    const swatch = document.createElement("span");
    swatch.className = "swatch";
    swatch.style.background = r.online ? colourOf(r.robot_id, ids) : OFFLINE;
    name.prepend(swatch);
    cell(tr, r.online ? "yes" : "no");
    cell(tr, fixed(r.obs_rate_hz, 1));
    // Trust: 1 / the covariance scale the fusion applies (1 = the robot is honest).
    cell(tr, r.covariance_scale == null ? "–" : (1 / r.covariance_scale).toFixed(2));
    cell(tr, r.latency_s == null ? "–" : `${(1000 * r.latency_s).toFixed(0)} ms`);
    cell(tr, r.outlier_rate == null ? "–" : `${(100 * r.outlier_rate).toFixed(0)} %`);
    // Clock: the server's estimate of server minus robot clock (positive: the robot is behind).
    const clock = cell(tr, r.clock_offset_s == null ? "–" : `${r.clock_offset_s >= 0 ? "+" : ""}${(1000 * r.clock_offset_s).toFixed(0)} ms`);
    if (r.clock_correction_s) {
      clock.textContent += " ✓";
    }
    if (r.clock_suspect) {
      clock.className = "suspect";
      clock.title = r.clock_correction_s
        ? `this robot's clock is off; the server corrects its stamps by ${(1000 * r.clock_correction_s).toFixed(0)} ms (synchronise it, e.g. with NTP)`
        : "this robot's clock is off: its sightings are placed at the wrong time (synchronise it, e.g. with NTP)";
    }
    return tr;
  });
  body.replaceChildren(...rows);
}

export function showRejected(rejected) {
  const list = el("rejected");
  const entries = Object.entries(rejected || {});
  if (!entries.length) {
    const li = document.createElement("li");
    li.textContent = "none";
    list.replaceChildren(li);
    return;
  }
  list.replaceChildren(...entries.map(([reason, n]) => {
    const li = document.createElement("li");
    li.dataset.reason = reason;
    li.textContent = `${reason.replace("/", ": ")} ${n}`;
    return li;
  }));
}

export function showServer(stats) {
  el("server").textContent =
    `${fixed(stats.frames_per_s, 1)} states/s received · drawing ${fixed(stats.draw_fps, 0)} frames/s · ` +
    `${stats.observations} sightings in the last 2 s`;
}

export function showIntercept(sel) {
  const p = el("intercept");
  if (!sel) {
    p.textContent = "No robot chosen.";
  } else if (sel.error) {
    p.textContent = `${sel.robot_id}: ${sel.error}`;
  } else if (sel.reply) {
    const i = sel.reply;
    p.textContent = `${i.robot_id} meets the ball in ${i.t_s.toFixed(1)} s at (${i.point_m[0].toFixed(2)}, ${i.point_m[1].toFixed(2)}) m` +
      (i.reachable_in_motion ? "" : " (after it stops)");
  } else {
    p.textContent = `${sel.robot_id}: asking…`;
  }
}
