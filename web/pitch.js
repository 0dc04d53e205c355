// The pitch to scale: robots with pose, heading and camera footprints, each robot's recent
// sightings (2σ ellipses fading with age, rejected ones crossed out with their reason), the
// fused ball with its 2σ ellipse, velocity arrow, trail and predicted path (bounces, stop),
// and a chosen robot's intercept. Drawing only: what to draw comes in, what was drawn
// (in CSS pixels) goes out for the page's debug object. The stop's and the intercept's
// labels are placed last, clear of each other, of the ball and of the robots' names.

import { LabelLayout } from "./labels.js";

export const OFFLINE = "#9e9e9e";
const PALETTE = ["#42a5f5", "#ab47bc", "#ffca28", "#26c6da", "#ec407a",
  "#9ccc65", "#ff7043", "#5c6bc0", "#8d6e63", "#f5f5f5"];
/// Sightings older than this (seconds since arrival) are no longer drawn.
export const FADE_S = 2.0;
const NS = 1e9;
const LABEL_FONT = "11px system-ui, sans-serif";
const LABEL_H_PX = 13;

export function colourOf(robotId, ids) {
  const i = ids.indexOf(robotId);
  return PALETTE[(i < 0 ? 0 : i) % PALETTE.length];
}

/// The 2σ ellipse of a 2×2 covariance [a, b, b, d]: semi-axes (m) and angle (rad).
export function ellipse2Sigma(a, b, d) {
  if (![a, b, d].every(Number.isFinite)) return null;
  const mid = (a + d) / 2;
  const r = Math.hypot((a - d) / 2, b);
  const l1 = mid + r;
  const l2 = mid - r;
  if (!(l1 > 0) || !(l2 > 0)) return null;
  return { major_m: 2 * Math.sqrt(l1), minor_m: 2 * Math.sqrt(l2), angle_rad: 0.5 * Math.atan2(2 * b, a - d) };
}

export class PitchView {
  constructor(canvas) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.cssW = 0;
    this.cssH = 0;
    this.transform = null;
  }

  /// Sizes the canvas backing store to its box (CSS width; height from the pitch).
  fit(pitch) {
    const ratio = window.devicePixelRatio || 1;
    const w = Math.max(200, this.canvas.clientWidth);
    const margin = 16;
    const scale = (w - 2 * margin) / pitch.length_m;
    const h = Math.round(pitch.width_m * scale + 2 * margin);
    if (w !== this.cssW || h !== this.cssH) {
      this.cssW = w;
      this.cssH = h;
      this.canvas.style.height = `${h}px`;
      this.canvas.width = Math.round(w * ratio);
      this.canvas.height = Math.round(h * ratio);
    }
    this.ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    // Field frame: origin at the centre, x right, y up.
    this.transform = { scale, cx: w / 2, cy: h / 2 };
  }

  X(x) { return this.transform.cx + x * this.transform.scale; }
  Y(y) { return this.transform.cy - y * this.transform.scale; }

  /// Field coordinates of a point in CSS pixels of the canvas.
  toField(px, py) {
    const t = this.transform;
    return t ? [(px - t.cx) / t.scale, -(py - t.cy) / t.scale] : null;
  }

  /// Draws one frame of `m` (see app.js) and returns what it drew.
  draw(m) {
    const out = { ball: null, robots: {}, ellipses: {}, rejected: {}, intercept: null, labels: [], stale: m.stale };
    const view = m.view;
    if (!view) return out;
    this.fit(view.pitch);
    this.layout = new LabelLayout({ x: 0, y: 0, w: this.cssW, h: this.cssH });
    this.queued = [];
    const ctx = this.ctx;
    ctx.clearRect(0, 0, this.cssW, this.cssH);
    this.field(view.pitch);
    const ids = m.robotIds;
    ctx.save();
    this.clipToPitch(view.pitch);
    this.footprints(view.robots);
    this.sightings(view, ids, out);
    ctx.restore();
    this.robots(view.robots, ids, m.selected, out);
    this.trail(m.trail);
    if (view.ball) this.ball(view.ball, view.pitch, out);
    if (m.intercept) this.intercept(m.intercept, view.robots, out);
    this.labels(out);
    if (m.stale) this.staleMark();
    return out;
  }

  field(p) {
    const ctx = this.ctx;
    const s = this.transform.scale;
    ctx.strokeStyle = "#fff";
    ctx.lineWidth = 2;
    ctx.strokeRect(this.X(-p.length_m / 2), this.Y(p.width_m / 2), p.length_m * s, p.width_m * s);
    ctx.beginPath();
    ctx.moveTo(this.X(0), this.Y(p.width_m / 2));
    ctx.lineTo(this.X(0), this.Y(-p.width_m / 2));
    ctx.stroke();
    ctx.beginPath();
    ctx.arc(this.X(0), this.Y(0), Math.min(p.width_m / 6, 0.4) * s, 0, 2 * Math.PI);
    ctx.stroke();
    // Walls: thicker where the ball bounces.
    ctx.strokeStyle = "#cfd8dc";
    ctx.lineWidth = 5;
    const L = p.length_m / 2, W = p.width_m / 2;
    const sides = { x_min: [[-L, -W], [-L, W]], x_max: [[L, -W], [L, W]], y_min: [[-L, -W], [L, -W]], y_max: [[-L, W], [L, W]] };
    for (const w of p.walls || []) {
      const seg = sides[w];
      if (!seg) continue;
      ctx.beginPath();
      ctx.moveTo(this.X(seg[0][0]), this.Y(seg[0][1]));
      ctx.lineTo(this.X(seg[1][0]), this.Y(seg[1][1]));
      ctx.stroke();
    }
  }

  clipToPitch(p) {
    const s = this.transform.scale;
    this.ctx.beginPath();
    this.ctx.rect(this.X(-p.length_m / 2), this.Y(p.width_m / 2), p.length_m * s, p.width_m * s);
    this.ctx.clip();
  }

  footprints(robots) {
    const ctx = this.ctx;
    ctx.fillStyle = "rgba(255, 255, 255, 0.07)";
    let n = 0;
    for (const r of robots) {
      if (!r.online || !r.status) continue;
      for (const f of r.status.footprints || []) {
        if (f.polygon_m.length < 3) continue;
        ctx.beginPath();
        ctx.moveTo(this.X(f.polygon_m[0][0]), this.Y(f.polygon_m[0][1]));
        for (const q of f.polygon_m) ctx.lineTo(this.X(q[0]), this.Y(q[1]));
        ctx.closePath();
        ctx.fill();
        n += 1;
      }
    }
    this.canvas.dataset.footprints = n;
  }

  /// Each robot's sightings of the last FADE_S seconds, in its colour, fading with age.
  sightings(view, ids, out) {
    const ctx = this.ctx;
    const s = this.transform.scale;
    ctx.lineWidth = 1.5;
    ctx.font = "10px system-ui, sans-serif";
    for (const o of view.observations || []) {
      const age_s = (view.stamp - o.received) / NS;
      if (!(age_s >= -0.05 && age_s <= FADE_S)) continue;
      const [x, y] = o.position_m || [];
      if (!Number.isFinite(x) || !Number.isFinite(y)) continue;
      ctx.globalAlpha = Math.max(0.1, 1 - Math.max(0, age_s) / FADE_S);
      const colour = colourOf(o.robot_id, ids);
      ctx.strokeStyle = colour;
      ctx.fillStyle = colour;
      const px = this.X(x), py = this.Y(y);
      if (o.accepted) {
        const c = o.covariance_m2;
        const e = ellipse2Sigma(c[0], c[1], c[3]);
        ctx.beginPath();
        if (e) ctx.ellipse(px, py, Math.max(1.5, e.major_m * s), Math.max(1.5, e.minor_m * s), -e.angle_rad, 0, 2 * Math.PI);
        else ctx.arc(px, py, 3, 0, 2 * Math.PI);
        ctx.stroke();
        out.ellipses[o.robot_id] = (out.ellipses[o.robot_id] || 0) + 1;
      } else {
        ctx.beginPath();
        ctx.moveTo(px - 5, py - 5); ctx.lineTo(px + 5, py + 5);
        ctx.moveTo(px + 5, py - 5); ctx.lineTo(px - 5, py + 5);
        ctx.stroke();
        ctx.fillText(o.reason || "rejected", px + 6, py - 6);
        const r = (out.rejected[o.robot_id] ||= {});
        r[o.reason] = (r[o.reason] || 0) + 1;
      }
    }
    ctx.globalAlpha = 1;
  }

  robots(robots, ids, selected, out) {
    const ctx = this.ctx;
    const s = this.transform.scale;
    const radius = Math.max(6, 0.1 * s);
    for (const r of robots) {
      if (!r.pose) continue;
      const px = this.X(r.pose.x_m), py = this.Y(r.pose.y_m);
      const body = r.online ? colourOf(r.robot_id, ids) : OFFLINE;
      ctx.fillStyle = body;
      ctx.strokeStyle = r.robot_id === selected ? "#fff" : "#263238";
      ctx.lineWidth = r.robot_id === selected ? 3 : 1.5;
      ctx.beginPath();
      ctx.arc(px, py, radius, 0, 2 * Math.PI);
      ctx.fill();
      ctx.stroke();
      ctx.strokeStyle = "#263238";
      ctx.lineWidth = 2;
      ctx.beginPath();
      ctx.moveTo(px, py);
      ctx.lineTo(px + 1.5 * radius * Math.cos(r.pose.theta_rad), py - 1.5 * radius * Math.sin(r.pose.theta_rad));
      ctx.stroke();
      const name = r.online ? r.robot_id : `${r.robot_id} (offline)`;
      this.layout.block({ x: px - radius, y: py - radius, w: 2 * radius, h: 2 * radius });
      // Named once every mark is drawn, where the name stays on the pitch and off the
      // ball, the stop and the other names (a robot at the edge is named on its inner side).
      this.queued.push({ kind: "robot", robot_id: r.robot_id, text: name, x: px + radius - 6, y: py - radius + 2,
        colour: r.online ? "#fff" : "#cfd8dc" });
      out.robots[r.robot_id] = { online: r.online, colour: body, px, py, radius_px: radius };
    }
  }

  trail(trail) {
    if (trail.length < 2) return;
    const ctx = this.ctx;
    ctx.lineWidth = 2;
    for (let i = 1; i < trail.length; i++) {
      ctx.strokeStyle = `rgba(255, 138, 101, ${(0.15 + 0.6 * i / trail.length).toFixed(2)})`;
      ctx.beginPath();
      ctx.moveTo(this.X(trail[i - 1].x), this.Y(trail[i - 1].y));
      ctx.lineTo(this.X(trail[i].x), this.Y(trail[i].y));
      ctx.stroke();
    }
  }

  ball(b, pitch, out) {
    const ctx = this.ctx;
    const s = this.transform.scale;
    const pred = b.prediction || { samples: [], bounces: [], stop: null };
    const path = pred.samples || [];
    // How sure the path is: each predicted point's 2σ ellipse (and the stop's), filled as
    // one shape, so the band widens where the server is less sure.
    const band = [];
    for (const p of path.concat(pred.stop ? [pred.stop] : [])) {
      const c = p.covariance_m2;
      const e = Array.isArray(c) && c.length === 4 ? ellipse2Sigma(c[0], 0.5 * (c[1] + c[2]), c[3]) : null;
      if (e) band.push({ x: this.X(p.position_m[0]), y: this.Y(p.position_m[1]), e });
    }
    if (band.length > 0) {
      ctx.fillStyle = "rgba(255, 235, 59, 0.16)";
      ctx.beginPath();
      for (const { x, y, e } of band) {
        const a = Math.max(1, e.major_m * s), b2 = Math.max(1, e.minor_m * s);
        ctx.moveTo(x + a * Math.cos(-e.angle_rad), y + a * Math.sin(-e.angle_rad));
        ctx.ellipse(x, y, a, b2, -e.angle_rad, 0, 2 * Math.PI);
      }
      ctx.fill("nonzero");
    }
    const pathBand = {
      ellipses: band.length,
      first_m: band.length ? band[0].e.major_m : 0,
      widest_m: band.reduce((m, { e }) => Math.max(m, e.major_m), 0),
    };
    if (path.length > 1) {
      ctx.strokeStyle = "#ffeb3b";
      ctx.lineWidth = 2;
      ctx.setLineDash([6, 4]);
      ctx.beginPath();
      ctx.moveTo(this.X(path[0].position_m[0]), this.Y(path[0].position_m[1]));
      for (const p of path) ctx.lineTo(this.X(p.position_m[0]), this.Y(p.position_m[1]));
      ctx.stroke();
      ctx.setLineDash([]);
    }
    ctx.fillStyle = "#ffeb3b";
    for (const bounce of pred.bounces || []) {
      const px = this.X(bounce.position_m[0]), py = this.Y(bounce.position_m[1]);
      ctx.beginPath();
      ctx.moveTo(px, py - 6); ctx.lineTo(px + 6, py); ctx.lineTo(px, py + 6); ctx.lineTo(px - 6, py);
      ctx.closePath();
      ctx.fill();
    }
    if (pred.stop) {
      const px = this.X(pred.stop.position_m[0]), py = this.Y(pred.stop.position_m[1]);
      ctx.strokeStyle = "#ffeb3b";
      ctx.lineWidth = 2;
      ctx.strokeRect(px - 5, py - 5, 10, 10);
      this.layout.block({ x: px - 6, y: py - 6, w: 12, h: 12 });
      this.queued.push({ kind: "stop", text: `stop ${pred.stop.t_s.toFixed(1)} s`, x: px, y: py, colour: "#ffeb3b" });
    }
    const [x, y] = b.position_m;
    const px = this.X(x), py = this.Y(y);
    // A ball the cameras look for and do not see fades (existence falls towards 0).
    const existence = typeof b.existence === "number" ? b.existence : 1;
    ctx.save();
    ctx.globalAlpha = 0.2 + 0.8 * Math.min(1, Math.max(0, existence));
    const c = b.covariance;
    const e = ellipse2Sigma(c[0], c[1], c[5]);
    if (e) {
      ctx.strokeStyle = "#ff5722";
      ctx.fillStyle = "rgba(255, 87, 34, 0.18)";
      ctx.lineWidth = 1.5;
      ctx.beginPath();
      ctx.ellipse(px, py, Math.max(2, e.major_m * s), Math.max(2, e.minor_m * s), -e.angle_rad, 0, 2 * Math.PI);
      ctx.fill();
      ctx.stroke();
    }
    const [vx, vy] = b.velocity_mps;
    if (Math.hypot(vx, vy) > 0.02) this.arrow(px, py, this.X(x + vx), this.Y(y + vy), "#ffffff");
    ctx.fillStyle = b.status === "tracking" || b.status === "stopped" ? "#ff5722" : "#ffab91";
    ctx.strokeStyle = "#3e2723";
    ctx.lineWidth = 1;
    const radius = Math.max(5, pitch.ball_radius_m * s);
    ctx.beginPath();
    ctx.arc(px, py, radius, 0, 2 * Math.PI);
    ctx.fill();
    ctx.stroke();
    ctx.restore();
    this.layout.block({ x: px - radius, y: py - radius, w: 2 * radius, h: 2 * radius }, true);
    out.ball = { x_m: x, y_m: y, px, py, radius_px: radius, status: b.status, ellipse: e, stamp: b.stamp, existence, path_band: pathBand };
  }

  arrow(x0, y0, x1, y1, colour) {
    const ctx = this.ctx;
    const a = Math.atan2(y1 - y0, x1 - x0);
    ctx.strokeStyle = colour;
    ctx.fillStyle = colour;
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.moveTo(x0, y0);
    ctx.lineTo(x1, y1);
    ctx.stroke();
    ctx.beginPath();
    ctx.moveTo(x1, y1);
    ctx.lineTo(x1 - 9 * Math.cos(a - 0.4), y1 - 9 * Math.sin(a - 0.4));
    ctx.lineTo(x1 - 9 * Math.cos(a + 0.4), y1 - 9 * Math.sin(a + 0.4));
    ctx.closePath();
    ctx.fill();
  }

  intercept(i, robots, out) {
    const ctx = this.ctx;
    const r = robots.find((q) => q.robot_id === i.robot_id);
    const px = this.X(i.point_m[0]), py = this.Y(i.point_m[1]);
    if (r && r.pose) {
      ctx.strokeStyle = "#e1f5fe";
      ctx.lineWidth = 1.5;
      ctx.setLineDash([3, 3]);
      ctx.beginPath();
      ctx.moveTo(this.X(r.pose.x_m), this.Y(r.pose.y_m));
      ctx.lineTo(px, py);
      ctx.stroke();
      ctx.setLineDash([]);
    }
    ctx.strokeStyle = "#e1f5fe";
    ctx.lineWidth = 3;
    ctx.beginPath();
    ctx.moveTo(px - 8, py); ctx.lineTo(px + 8, py);
    ctx.moveTo(px, py - 8); ctx.lineTo(px, py + 8);
    ctx.stroke();
    this.layout.block({ x: px - 9, y: py - 9, w: 18, h: 18 });
    const chance = typeof i.probability === "number" ? ` · ${Math.round(100 * i.probability)} %` : "";
    this.queued.push({ kind: "intercept", text: `${i.robot_id} ${i.t_s.toFixed(1)} s${chance}`, x: px, y: py, colour: "#e1f5fe" });
    out.intercept = { robot_id: i.robot_id, point_m: i.point_m, t_s: i.t_s, probability: i.probability ?? null, px, py };
  }

  /// The labels queued while drawing, each where it covers nothing drawn or placed before it.
  labels(out) {
    const ctx = this.ctx;
    ctx.font = LABEL_FONT;
    ctx.textBaseline = "top";
    // The stop and the intercept first: the robots' names keep off them.
    const order = [...this.queued].sort((a, b) => (a.kind === "robot") - (b.kind === "robot"));
    for (const q of order) {
      const box = this.layout.place(q.x, q.y, ctx.measureText(q.text).width, LABEL_H_PX);
      // A dark backing keeps the text readable over ellipses and trails.
      ctx.fillStyle = "rgba(27, 94, 32, 0.6)";
      ctx.fillRect(box.x - 1, box.y - 1, box.w + 2, box.h + 1);
      ctx.fillStyle = q.colour;
      ctx.fillText(q.text, box.x, box.y + 1);
      out.labels.push({ kind: q.kind, text: q.text, ...box });
    }
    ctx.textBaseline = "alphabetic";
  }

  staleMark() {
    const ctx = this.ctx;
    ctx.fillStyle = "rgba(0, 0, 0, 0.35)";
    ctx.fillRect(0, 0, this.cssW, this.cssH);
    ctx.fillStyle = "#fff";
    ctx.font = "bold 22px system-ui, sans-serif";
    ctx.textAlign = "center";
    ctx.fillText("STALE: no state from the server", this.cssW / 2, this.cssH / 2);
    ctx.textAlign = "start";
  }
}
