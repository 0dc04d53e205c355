// One camera of the chosen robot: its newest view's JPEG on a canvas with every candidate the
// detector scored drawn over it (the published ball bold, runners-up faint, rejected ones in
// red), the stage, outcome, reason and score of the candidate under the pointer (or finger)
// in a tip, and a caption with the view's age, time and detector time. Drawing only: the
// view comes in, what was drawn goes out for the page's debug object.

import { clockText } from "./replay.js";

const NS = 1e9;
/// How far outside a candidate's circle the pointer still picks it, px.
const PICK_PX = 4;
const STYLE = {
  ball: { stroke: "#ffeb3b", width: 3, dash: [] },
  runner_up: { stroke: "rgba(255, 255, 255, 0.6)", width: 1.5, dash: [3, 2] },
  rejected: { stroke: "rgba(229, 57, 53, 0.85)", width: 1.5, dash: [] },
};
/// Drawn bottom to top: the ball over the rest.
const ORDER = { rejected: 0, runner_up: 1, ball: 2 };

function make(tag, className, parent) {
  const e = document.createElement(tag);
  if (className) e.className = className;
  if (parent) parent.appendChild(e);
  return e;
}

/// When a view was taken: the match clock in a replay, the time of day live.
function whenText(stamp, replay) {
  if (replay) return `at ${clockText((stamp - replay.start) / NS)}`;
  const d = new Date(stamp / 1e6);
  return `at ${d.toLocaleTimeString("en-GB", { hour12: false })}.${Math.floor(d.getMilliseconds() / 100)}`;
}

export function tipText(c) {
  const what = c.outcome === "rejected" ? `rejected: ${c.reason || "no reason given"}` : c.outcome.replace("_", "-");
  return `${what} · score ${c.score.toFixed(2)} · ${c.stage} · r ${c.radius_px.toFixed(1)} px`;
}

export class CameraFigure {
  constructor(camera, parent) {
    this.camera = camera;
    this.figure = make("figure", "cam", parent);
    this.figure.dataset.camera = camera;
    const box = make("div", "cam-box", this.figure);
    this.canvas = make("canvas", null, box);
    this.canvas.setAttribute("aria-label", `the ${camera} camera's view with the detector's candidates`);
    this.empty = make("p", "cam-empty", box);
    this.tip = make("div", "tip", box);
    this.tip.hidden = true;
    this.caption = make("figcaption", null, this.figure);
    this.ctx = this.canvas.getContext("2d");
    this.drawnKey = null;
    this.circles = [];
    this.pointer = null;
    this.drawn = null;
    const pick = (e) => {
      const r = this.canvas.getBoundingClientRect();
      this.pointer = { x: e.clientX - r.left, y: e.clientY - r.top };
      this.showTip();
    };
    this.canvas.addEventListener("pointermove", pick);
    this.canvas.addEventListener("pointerdown", pick);
    this.canvas.addEventListener("pointerleave", () => {
      this.pointer = null;
      this.showTip();
    });
  }

  /// Draws `shown` (a kept view with its image, or null); `clock` is the page's match time (ns).
  draw({ robotId, shown, pending, clock, replay }) {
    const cssW = this.canvas.parentElement.clientWidth;
    if (!shown) {
      this.canvas.hidden = true;
      this.empty.hidden = false;
      this.empty.textContent = pending ? `the ${this.camera} camera: decoding…` : `no view of the ${this.camera} camera`;
      this.caption.textContent = this.camera;
      this.drawnKey = null;
      this.circles = [];
      this.drawn = null;
      this.showTip();
      return null;
    }
    const v = shown.view;
    this.canvas.hidden = false;
    this.empty.hidden = true;
    const key = `${robotId}|${v.seq}|${v.stamp}|${cssW}|${shown.loaded}`;
    if (key !== this.drawnKey && cssW > 0) {
      this.drawnKey = key;
      this.paint(shown, cssW);
      this.showTip();
    }
    const age_s = Math.max(0, (clock - v.stamp) / NS);
    const balls = v.candidates.filter((c) => c.outcome === "ball").length;
    const text = `${this.camera} · ${age_s.toFixed(1)} s old, ${whenText(v.stamp, replay)} · ` +
      `detector ${v.detector_ms.toFixed(1)} ms · ${v.candidates.length} candidates, ${balls ? "ball found" : "no ball"}`;
    if (this.caption.textContent !== text) this.caption.textContent = text;
    this.drawn = {
      stamp: v.stamp, seq: v.seq, age_s, candidates: v.candidates.length, imgLoaded: shown.loaded,
      ballDrawn: this.circles.some((c) => c.c.outcome === "ball"),
      circles: this.circles.map((c) => ({ px: c.px, py: c.py, r_px: c.r, outcome: c.c.outcome, reason: c.c.reason, score: c.c.score })),
      tip: this.tip.hidden ? null : this.tip.textContent,
      width_px: this.canvasW, height_px: this.canvasH,
    };
    return this.drawn;
  }

  /// The image scaled to `cssW` CSS pixels wide, the candidates over it.
  paint(shown, cssW) {
    const v = shown.view;
    const ratio = window.devicePixelRatio || 1;
    const scale = cssW / v.width_px;
    const cssH = Math.round(v.height_px * scale);
    this.canvasW = cssW;
    this.canvasH = cssH;
    this.canvas.style.height = `${cssH}px`;
    this.canvas.width = Math.round(cssW * ratio);
    this.canvas.height = Math.round(cssH * ratio);
    const ctx = this.ctx;
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    if (shown.loaded) {
      ctx.drawImage(shown.image, 0, 0, cssW, cssH);
    } else {
      ctx.fillStyle = "#455a64";
      ctx.fillRect(0, 0, cssW, cssH);
      ctx.fillStyle = "#fff";
      ctx.font = "12px system-ui, sans-serif";
      ctx.fillText("image unreadable", 8, 18);
    }
    const sorted = [...v.candidates].sort((a, b) => (ORDER[a.outcome] ?? 0) - (ORDER[b.outcome] ?? 0));
    this.circles = sorted.map((c) => ({ c, px: c.u_px * scale, py: c.v_px * scale, r: Math.max(3, c.radius_px * scale) }));
    for (const k of this.circles) {
      const style = STYLE[k.c.outcome] || STYLE.rejected;
      ctx.strokeStyle = style.stroke;
      ctx.lineWidth = style.width;
      ctx.setLineDash(style.dash);
      ctx.beginPath();
      ctx.arc(k.px, k.py, k.r, 0, 2 * Math.PI);
      ctx.stroke();
    }
    ctx.setLineDash([]);
    const ball = this.circles.find((k) => k.c.outcome === "ball");
    if (ball) {
      ctx.font = "bold 11px system-ui, sans-serif";
      const text = `ball ${ball.c.score.toFixed(2)}`;
      const w = ctx.measureText(text).width;
      const x = Math.min(Math.max(0, ball.px - w / 2), cssW - w);
      const y = ball.py - ball.r - 4 > 12 ? ball.py - ball.r - 4 : ball.py + ball.r + 13;
      ctx.lineWidth = 3;
      ctx.strokeStyle = "rgba(0, 0, 0, 0.7)";
      ctx.strokeText(text, x, y);
      ctx.fillStyle = STYLE.ball.stroke;
      ctx.fillText(text, x, y);
    }
  }

  /// The candidate under the pointer (the nearest, the ball first on a tie), in the tip.
  showTip() {
    const p = this.pointer;
    let best = null;
    if (p) {
      for (const k of this.circles) {
        const d = Math.hypot(p.x - k.px, p.y - k.py);
        if (d <= k.r + PICK_PX && (!best || d <= best.d)) best = { k, d };
      }
    }
    if (!best) {
      this.tip.hidden = true;
      return;
    }
    this.tip.textContent = tipText(best.k.c);
    this.tip.dataset.outcome = best.k.c.outcome;
    this.tip.hidden = false;
    // Beside the candidate, inside the image: never wider than the screen.
    const boxW = this.canvas.parentElement.clientWidth;
    const x = Math.min(Math.max(0, best.k.px + best.k.r + 4), Math.max(0, boxW - this.tip.offsetWidth));
    const below = best.k.py + best.k.r + 4;
    const y = below + this.tip.offsetHeight <= this.canvasH ? below : Math.max(0, best.k.py - best.k.r - 4 - this.tip.offsetHeight);
    this.tip.style.left = `${x}px`;
    this.tip.style.top = `${y}px`;
  }
}
