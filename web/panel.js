// The side panel: the ball's facts, the robots' table, the chosen robot's perception per
// camera, rejected inputs by reason and the server's rate. Rebuilt a few times a second,
// never on every frame.

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
    for (const id of ["ball-status", "ball-existence", "ball-pos", "ball-speed", "ball-ellipse", "ball-decel", "ball-restitution", "ball-events", "ball-stop", "ball-contributors"]) {
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
  el("ball-events").textContent = `${m.bounces_seen ?? 0} bounces, ${m.kicks_inferred ?? 0} kicks inferred`;
  el("ball-stop").textContent = stop
    ? `in ${stop.t_s.toFixed(1)} s at (${stop.position_m[0].toFixed(2)}, ${stop.position_m[1].toFixed(2)}) m`
    : "–";
  el("ball-contributors").textContent = b.contributors.length ? b.contributors.join(", ") : "nobody lately";
  el("ball").textContent = `ball: ${b.status} at (${b.position_m[0].toFixed(2)}, ${b.position_m[1].toFixed(2)}) m, ${speed.toFixed(2)} m/s`;
}

/// The text of a cell, set only when it changed.
function setText(td, text) {
  if (td.textContent !== text) td.textContent = text;
}

/// One row per robot, kept from one refresh to the next (a click must not land on a row
/// that was just replaced); `selected` is marked.
export function showRobots(robots, ids, selected) {
  const body = el("robots");
  const old = new Map([...body.children].map((tr) => [tr.dataset.robot, tr]));
  const rows = robots.map((r) => {
    let tr = old.get(r.robot_id);
    if (!tr) {
      tr = document.createElement("tr");
      tr.dataset.robot = r.robot_id;
      tr.tabIndex = 0;
      tr.title = `${r.robot_id}: show what it sees`;
      for (let i = 0; i < 7; i++) tr.appendChild(document.createElement("td"));
      const swatch = document.createElement("span");
      swatch.className = "swatch";
      tr.children[0].append(swatch, document.createTextNode(r.robot_id));
    }
    const td = tr.children;
    tr.dataset.online = r.online ? "yes" : "no";
    tr.classList.toggle("off", !r.online);
    tr.classList.toggle("selected", r.robot_id === selected);
    tr.setAttribute("aria-selected", r.robot_id === selected ? "true" : "false");
    td[0].firstChild.style.background = r.online ? colourOf(r.robot_id, ids) : OFFLINE;
    setText(td[1], r.online ? "yes" : "no");
    setText(td[2], fixed(r.obs_rate_hz, 1));
    // Trust: 1 / the covariance scale the fusion applies (1 = the robot is honest).
    setText(td[3], r.covariance_scale == null ? "–" : (1 / r.covariance_scale).toFixed(2));
    setText(td[4], r.latency_s == null ? "–" : `${(1000 * r.latency_s).toFixed(0)} ms`);
    setText(td[5], r.outlier_rate == null ? "–" : `${(100 * r.outlier_rate).toFixed(0)} %`);
    // Clock: the server's estimate of server minus robot clock (positive: the robot is behind).
    const clock = td[6];
    setText(clock, (r.clock_offset_s == null ? "–" : `${r.clock_offset_s >= 0 ? "+" : ""}${(1000 * r.clock_offset_s).toFixed(0)} ms`) +
      (r.clock_correction_s ? " ✓" : ""));
    clock.className = r.clock_suspect ? "suspect" : "";
    clock.title = !r.clock_suspect ? "" : r.clock_correction_s
      ? `this robot's clock is off; the server corrects its stamps by ${(1000 * r.clock_correction_s).toFixed(0)} ms (synchronise it, e.g. with NTP)`
      : "this robot's clock is off: its sightings are placed at the wrong time (synchronise it, e.g. with NTP)";
    return tr;
  });
  const now = [...body.children];
  if (rows.length !== now.length || rows.some((tr, i) => tr !== now[i])) body.replaceChildren(...rows);
}

/// The chosen robot's perception per camera, as its status reports it (`cameras`), or why
/// there is none.
export function showPerception(robotId, status) {
  const body = el("sight-health").tBodies[0];
  const cams = (status && status.cameras) || [];
  el("sight-health").hidden = !cams.length;
  el("sight-health-note").hidden = cams.length > 0;
  el("sight-health-note").textContent = status
    ? `${robotId} reports no camera counters.`
    : `${robotId} has sent no status.`;
  body.replaceChildren(...cams.map((c) => {
    const tr = document.createElement("tr");
    tr.dataset.camera = c.camera;
    cell(tr, c.camera);
    cell(tr, fixed(c.frames_per_s, 1));
    cell(tr, fixed(c.candidates_per_frame, 2));
    cell(tr, fixed(c.balls_per_s, 1));
    cell(tr, fixed(c.detector_ms, 1, " ms"));
    return tr;
  }));
  const list = el("sight-rejections");
  list.replaceChildren(...cams.map((c) => {
    const li = document.createElement("li");
    li.dataset.camera = c.camera;
    const reasons = Object.entries(c.rejections || {}).sort((a, b) => b[1] - a[1]);
    li.textContent = `${c.camera} rejected: ${reasons.length ? reasons.map(([r, n]) => `${r} ${n}`).join(", ") : "none"}` +
      ` (of ${c.candidates} candidates in ${c.frames} frames, ${c.balls} balls)`;
    return li;
  }));
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

/// How the match log's recording stands (`recording` of the state view, null when the
/// server records nothing): a stopped recording is said in the header too, in red.
export function showRecording(rec) {
  const p = el("recording");
  const alert = el("rec-alert");
  if (!rec) {
    p.textContent = "not recording";
    p.classList.remove("stopped");
    alert.hidden = true;
    return;
  }
  if (rec.stopped) {
    const since = typeof rec.stopped_for_s === "number" ? ` ${Math.round(rec.stopped_for_s)} s ago` : "";
    p.textContent = `Recording stopped${since}: ${rec.reason}. ${rec.lost_since_stopped} messages not recorded since; ` +
      "it resumes into a new file as soon as writing succeeds. The ball is still served.";
    p.classList.add("stopped");
    alert.textContent = "recording stopped";
    alert.hidden = false;
    return;
  }
  const file = rec.file ? String(rec.file).split("/").pop() : "a new file";
  const resumed = rec.resumed ? ` (resumed ${rec.resumed}× after stopping)` : "";
  p.textContent = `Recording to ${file}${resumed}.`;
  p.classList.remove("stopped");
  alert.hidden = true;
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
      (i.reachable_in_motion ? "" : " (after it stops)") +
      (typeof i.probability === "number" ? `, ${Math.round(100 * i.probability)} % likely within its reach` : "");
  } else {
    p.textContent = `${sel.robot_id}: asking…`;
  }
}
