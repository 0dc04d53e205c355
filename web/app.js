// The coach's page. The live stream (/api/stream) pushes one JSON frame per published state:
// { stamp, ball, robots, pitch, observations, rejected, replay }. Frames only update the
// model; drawing runs on requestAnimationFrame, the panel a few times a second.
//
// A robot chosen (on the pitch or in the robots' table) gets its intercept and its two
// cameras' newest views (views.js, drawn by camera.js) with its perception per camera.
//
// For tests and curious users, `window.__teamBall` is a read-only snapshot of what the page
// shows: connection state, the ball and robots as drawn (field and canvas CSS pixels), the
// sightings drawn per robot, the replay, the chosen robot's intercept and the camera views
// (`views`: per "robot/camera" the newest kept, and for the chosen robot what is drawn).

import { PitchView } from "./pitch.js";
import { StripChart } from "./chart.js";
import { ReplayBar } from "./replay.js";
import { CameraFigure } from "./camera.js";
import { CAMERAS, ViewStream, viewKey } from "./views.js";
import { showBall, showIntercept, showPerception, showRecording, showRejected, showRobots, showServer } from "./panel.js";

/// No state for this long: the page says the picture is stale.
const STALE_MS = 1500;
/// Reconnection delays grow from the first to the last.
const RETRY_MS = [250, 500, 1000, 2000, 4000];
/// Length of the ball's trail and of the strip charts (match time).
const TRAIL_S = 8;
const HISTORY_S = 30;
const PANEL_EVERY_MS = 250;
const INTERCEPT_EVERY_MS = 1000;
const NS = 1e9;

const el = (id) => document.getElementById(id);

const model = {
  view: null,
  receivedAt: 0,
  connection: "connecting",
  connectionText: "connecting…",
  frames: 0,
  arrivals: [],
  trail: [],
  history: [],
  robotIds: [],
  selected: null,
  interceptReply: null,
  interceptError: null,
  retries: 0,
};

const pitch = new PitchView(el("pitch"));
const speedChart = new StripChart(el("chart-speed"), { label: "speed", unit: "m/s", colour: "#e64a19", window_s: HISTORY_S });
const ellipseChart = new StripChart(el("chart-ellipse"), { label: "2σ ellipse (major)", unit: "cm", colour: "#1565c0", window_s: HISTORY_S });
const replayBar = new ReplayBar();
const views = new ViewStream();
const figures = Object.fromEntries(CAMERAS.map((cam) => [cam, new CameraFigure(cam, el("sight-cameras"))]));
let drawn = { ball: null, robots: {}, ellipses: {}, rejected: {}, intercept: null };
const drawTimes = [];
let lastPanel = 0;

function setConnection(state, text) {
  model.connection = state;
  model.connectionText = text;
}

/// The connection as shown: "stale" when live but no state came for a while.
function showConnection(now) {
  let state = model.connection;
  let text = model.connectionText;
  if (state === "live" && now - model.receivedAt > STALE_MS) {
    state = "stale";
    text = `stale: no state for ${((now - model.receivedAt) / 1000).toFixed(1)} s`;
  }
  const c = el("conn");
  if (c.dataset.state !== state) {
    c.className = state;
    c.dataset.state = state;
  }
  if (c.textContent !== text) c.textContent = text;
  return state;
}

/// One frame from the stream.
function onFrame(view) {
  const prev = model.view;
  model.view = view;
  model.receivedAt = performance.now();
  model.frames += 1;
  model.arrivals.push(model.receivedAt);
  while (model.arrivals.length && model.receivedAt - model.arrivals[0] > 2000) model.arrivals.shift();
  const t_s = view.stamp / NS;
  // The match time jumped (a replay moved): history before it no longer leads here.
  if (prev && (t_s < prev.stamp / NS - 0.01 || t_s - prev.stamp / NS > 5)) {
    model.trail = [];
    model.history = [];
  }
  // Back in time: the views from after the new time were never seen there. The server
  // re-sends each camera's newest view up to it.
  if (prev && t_s < prev.stamp / NS - 0.01) views.forgetAfter(view.stamp);
  model.robotIds = [...new Set([...model.robotIds, ...view.robots.map((r) => r.robot_id)])]
    .sort((a, b) => a.localeCompare(b, "en", { numeric: true }));
  const b = view.ball;
  if (b) {
    const last = model.trail[model.trail.length - 1];
    if (!last || last.t_s !== t_s) model.trail.push({ t_s, x: b.position_m[0], y: b.position_m[1] });
    const c = b.covariance;
    const mid = (c[0] + c[5]) / 2;
    const major_cm = 200 * Math.sqrt(Math.max(0, mid + Math.hypot((c[0] - c[5]) / 2, c[1])));
    // Only when time moved on: a paused replay repeats one state.
    const lastH = model.history[model.history.length - 1];
    if (!lastH || lastH.t_s !== t_s) {
      model.history.push({ t_s, speed: Math.hypot(b.velocity_mps[0], b.velocity_mps[1]), ellipse_cm: major_cm });
    }
  }
  while (model.trail.length && t_s - model.trail[0].t_s > TRAIL_S) model.trail.shift();
  while (model.history.length && t_s - model.history[0].t_s > HISTORY_S) model.history.shift();
  replayBar.show(view.replay || null);
  replayBar.streamed();
}

/// The ball's last half minute from the server, so that a page that has just opened (or
/// reconnected) shows the charts and the trail at once; the stream carries on from there.
async function loadHistory() {
  try {
    const r = await fetch("/api/history");
    if (!r.ok) return;
    const h = await r.json();
    const past = h.samples.map((s) => ({
      t_s: s.stamp / NS,
      x: s.position_m[0],
      y: s.position_m[1],
      speed: Math.hypot(s.velocity_mps[0], s.velocity_mps[1]),
      ellipse_cm: 100 * s.ellipse_2sigma_m,
    }));
    const firstH = model.history.length ? model.history[0].t_s : Infinity;
    const older = past.filter((s) => s.t_s < firstH - 1e-6);
    model.history = [...older.map(({ t_s, speed, ellipse_cm }) => ({ t_s, speed, ellipse_cm })), ...model.history];
    const firstT = model.trail.length ? model.trail[0].t_s : Infinity;
    const now_s = h.stamp / NS;
    const trail = past.filter((s) => s.t_s < firstT - 1e-6 && now_s - s.t_s <= TRAIL_S);
    model.trail = [...trail.map(({ t_s, x, y }) => ({ t_s, x, y })), ...model.trail];
    model.historyLoaded = past.length;
  } catch {
    // The stream fills the charts by itself.
  }
}

function connect() {
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/api/stream`);
  ws.onopen = () => {
    loadHistory();
    model.retries = 0;
    model.receivedAt = performance.now();
    setConnection("live", "live");
  };
  ws.onmessage = (m) => {
    try {
      onFrame(JSON.parse(m.data));
    } catch (e) {
      console.warn("a frame the page could not read", e);
    }
  };
  ws.onclose = () => {
    const wait = RETRY_MS[Math.min(model.retries, RETRY_MS.length - 1)];
    model.retries += 1;
    setConnection("down", `disconnected, retrying in ${(wait / 1000).toFixed(1)} s…`);
    setTimeout(connect, wait);
  };
}

/// Asks where the chosen robot meets the ball.
async function askIntercept() {
  const id = model.selected;
  const v = model.view;
  // Only when there is something to answer: no 404s for a ball not seen or a robot gone,
  // nor while a replay's seek may have left the robot behind.
  if (!id || !v || !v.ball || !v.robots.some((r) => r.robot_id === id && r.pose)) return;
  if (replayBar.settling()) return;
  try {
    const r = await fetch(`/api/intercept?robot=${encodeURIComponent(id)}`);
    const body = await r.json();
    if (model.selected !== id) return;
    if (r.ok) {
      model.interceptReply = body;
      model.interceptError = null;
    } else {
      model.interceptReply = null;
      model.interceptError = body.error || `HTTP ${r.status}`;
    }
  } catch (e) {
    model.interceptError = e.message;
  }
}

function robotAt(px, py) {
  let best = null;
  for (const [id, r] of Object.entries(drawn.robots)) {
    const d = Math.hypot(px - r.px, py - r.py);
    if (d <= Math.max(14, r.radius_px + 6) && (!best || d < best.d)) best = { id, d };
  }
  return best && best.id;
}

/// Chooses a robot (null: none): its intercept, its cameras.
function select(id) {
  if (id === model.selected) return;
  model.selected = id;
  model.interceptReply = null;
  model.interceptError = null;
  views.want(Boolean(id));
  el("sight").hidden = !id;
  if (id) {
    el("sight-title").textContent = `Cameras of ${id}`;
    askIntercept();
  }
  lastPanel = 0;
}

el("pitch").addEventListener("click", (e) => {
  const box = e.currentTarget.getBoundingClientRect();
  select(robotAt(e.clientX - box.left, e.clientY - box.top));
});

/// A robot chosen in the table: its cameras, at the top of the panel, come into sight.
function selectRow(row) {
  select(row.dataset.robot);
  el("sight").scrollIntoView({ block: "nearest" });
}
el("robots").addEventListener("click", (e) => {
  const row = e.target.closest("tr[data-robot]");
  if (row) selectRow(row);
});
el("robots").addEventListener("keydown", (e) => {
  const row = e.target.closest("tr[data-robot]");
  if (row && (e.key === "Enter" || e.key === " ")) {
    e.preventDefault();
    selectRow(row);
  }
});
el("sight-close").addEventListener("click", () => select(null));
setInterval(askIntercept, INTERCEPT_EVERY_MS);

function frame(now) {
  const stale = showConnection(now) === "stale";
  drawn = pitch.draw({
    view: model.view,
    robotIds: model.robotIds,
    trail: model.trail,
    selected: model.selected,
    intercept: model.selected ? model.interceptReply : null,
    stale,
  });
  if (model.selected && model.view) drawSight(model.selected, model.view);
  drawTimes.push(now);
  while (drawTimes.length && now - drawTimes[0] > 2000) drawTimes.shift();
  if (now - lastPanel > PANEL_EVERY_MS && model.view) {
    lastPanel = now;
    const v = model.view;
    showBall(v.ball);
    showRobots(v.robots, model.robotIds, model.selected);
    if (model.selected) {
      const r = v.robots.find((q) => q.robot_id === model.selected);
      showPerception(model.selected, r && r.status);
    }
    showRejected(v.rejected);
    showRecording(v.recording);
    showServer({ frames_per_s: rate(model.arrivals), draw_fps: rate(drawTimes), observations: (v.observations || []).length });
    showIntercept(model.selected && { robot_id: model.selected, reply: model.interceptReply, error: model.interceptError });
    const t = v.stamp / NS;
    speedChart.draw(model.history.map((h) => ({ t_s: h.t_s, v: h.speed })), t);
    ellipseChart.draw(model.history.map((h) => ({ t_s: h.t_s, v: h.ellipse_cm })), t);
  }
  requestAnimationFrame(frame);
}

/// The chosen robot's cameras, each redrawn when its view or its size changed.
function drawSight(id, v) {
  for (const cam of CAMERAS) {
    figures[cam].draw({ robotId: id, ...views.ready(id, cam), clock: v.stamp, replay: v.replay || null });
  }
  const note = el("sight-note");
  let text = "";
  if (views.state === "connecting") text = "connecting to the camera views…";
  else if (views.state === "down") text = "camera views: disconnected, retrying…";
  else if (!views.has(id)) text = `No camera views from ${id}${v.replay ? " up to this time of the match" : ""}.`;
  note.hidden = !text;
  if (note.textContent !== text) note.textContent = text;
}

/// The views for the debug snapshot: every one kept, with what is drawn of the chosen robot's.
function viewsShown() {
  const out = views.summary();
  for (const cam of CAMERAS) {
    const d = model.selected && figures[cam].drawn;
    if (!d) continue;
    const key = viewKey(model.selected, cam);
    out[key] = { ...out[key], latestStamp: out[key] ? out[key].stamp : null, drawn: true, ...d };
  }
  return out;
}

/// Events per second over the times kept (the last 2 s).
function rate(times) {
  if (times.length < 2) return 0;
  return (times.length - 1) / ((times[times.length - 1] - times[0]) / 1000);
}

Object.defineProperty(window, "__teamBall", {
  enumerable: true,
  get() {
    const v = model.view;
    return structuredClone({
      connection: el("conn").dataset.state,
      frames: model.frames,
      stamp: v ? v.stamp : null,
      ball: drawn.ball,
      robots: drawn.robots,
      ellipses: drawn.ellipses,
      rejected: drawn.rejected,
      selected: model.selected,
      intercept: drawn.intercept,
      labels: drawn.labels,
      views: viewsShown(),
      viewStream: views.state,
      sightNote: model.selected && !el("sight-note").hidden ? el("sight-note").textContent : null,
      interceptError: model.interceptError,
      replay: v ? v.replay || null : null,
      replayClock: el("replay-clock").textContent,
      trail: model.trail.length,
      history: model.history.length,
      historyLoaded: model.historyLoaded || 0,
      drawFps: rate(drawTimes),
      framesPerS: rate(model.arrivals),
      canvas: { width_px: pitch.cssW, height_px: pitch.cssH },
    });
  },
});

connect();
requestAnimationFrame(frame);
