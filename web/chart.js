// A strip chart: one quantity over the last few seconds of match time, newest on the right.

export class StripChart {
  constructor(canvas, { label, unit, colour, window_s }) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.label = label;
    this.unit = unit;
    this.colour = colour;
    this.window_s = window_s;
  }

  /// `samples`: [{ t_s, v }] oldest first, `now_s` the right edge (same time axis).
  draw(samples, now_s) {
    const ratio = window.devicePixelRatio || 1;
    const w = Math.max(100, this.canvas.clientWidth);
    const h = Math.max(40, this.canvas.clientHeight);
    if (this.canvas.width !== Math.round(w * ratio) || this.canvas.height !== Math.round(h * ratio)) {
      this.canvas.width = Math.round(w * ratio);
      this.canvas.height = Math.round(h * ratio);
    }
    const ctx = this.ctx;
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    ctx.clearRect(0, 0, w, h);
    ctx.fillStyle = "#fafafa";
    ctx.fillRect(0, 0, w, h);
    const shown = samples.filter((s) => now_s - s.t_s <= this.window_s && Number.isFinite(s.v));
    const top = Math.max(1e-6, ...shown.map((s) => s.v)) * 1.15;
    const X = (t) => w - ((now_s - t) / this.window_s) * w;
    const Y = (v) => h - 4 - (v / top) * (h - 18);
    ctx.strokeStyle = this.colour;
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    shown.forEach((s, i) => (i ? ctx.lineTo(X(s.t_s), Y(s.v)) : ctx.moveTo(X(s.t_s), Y(s.v))));
    ctx.stroke();
    const last = shown.length ? shown[shown.length - 1].v : null;
    ctx.fillStyle = "#333";
    ctx.font = "11px system-ui, sans-serif";
    const now = last == null ? "–" : `${last.toFixed(2)} ${this.unit}`;
    ctx.fillText(`${this.label}: ${now} (max ${top === 1e-6 * 1.15 ? "–" : (top / 1.15).toFixed(2)}, last ${this.window_s} s)`, 4, 12);
    return shown.length;
  }
}
