// The replay bar: shown when the server replays a match log. Play/pause, speed, a timeline
// to seek and the match clock, through POST /api/replay/{pause,play,seek,speed}. A server
// with a control token answers 401: the bar then asks for the token (kept for the tab).

const el = (id) => document.getElementById(id);

export function clockText(t_s) {
  if (!Number.isFinite(t_s)) return "–";
  const m = Math.floor(t_s / 60);
  const s = t_s - 60 * m;
  return `${m}:${s.toFixed(1).padStart(4, "0")}`;
}

export class ReplayBar {
  constructor() {
    this.status = null;
    this.dragging = false;
    this.pending = 0;
    el("replay-toggle").addEventListener("click", () =>
      this.send(this.status && this.status.paused ? "play" : "pause"));
    el("replay-speed").addEventListener("change", (e) => this.send("speed", { speed: Number(e.target.value) }));
    const seek = el("replay-seek");
    seek.addEventListener("input", () => {
      this.dragging = true;
      el("replay-clock").textContent = `${clockText(Number(seek.value))} / ${clockText(Number(seek.max))}`;
    });
    seek.addEventListener("change", async () => {
      await this.send("seek", { t_s: Number(seek.value) });
      this.dragging = false;
    });
    el("replay-token").addEventListener("change", (e) => {
      sessionStorage.setItem("teamBallControlToken", e.target.value.trim());
      el("replay-msg").textContent = "";
    });
  }

  /// Whether a seek is under way or answered with no state from the stream since: the
  /// page's state may still be from before it (a robot in it may not exist at the new time).
  settling() {
    return this.pending > 0 || Boolean(this.afterSeek);
  }

  /// A state came from the stream: whatever was sought is in it.
  streamed() {
    this.afterSeek = false;
  }

  /// The latest status from the stream (`null`: not a replay).
  show(status) {
    this.status = status;
    const bar = el("replay");
    bar.hidden = !status;
    if (!status) return;
    el("replay-toggle").textContent = status.paused ? "Play" : "Pause";
    el("replay-toggle").dataset.paused = status.paused;
    const seek = el("replay-seek");
    seek.max = status.duration_s.toFixed(1);
    const speed = el("replay-speed");
    if (document.activeElement !== speed && Number(speed.value) !== status.speed) {
      if (![...speed.options].some((o) => Number(o.value) === status.speed)) {
        speed.add(new Option(`${status.speed}×`, String(status.speed)));
      }
      speed.value = String(status.speed);
    }
    if (!this.dragging && !this.pending) {
      seek.value = status.t_s.toFixed(1);
      el("replay-clock").textContent =
        `${clockText(status.t_s)} / ${clockText(status.duration_s)}${status.ended ? " (end)" : ""}`;
    }
  }

  async send(action, body) {
    const headers = { "Content-Type": "application/json" };
    const token = sessionStorage.getItem("teamBallControlToken");
    if (token) headers.Authorization = `Bearer ${token}`;
    this.pending += 1;
    let r, answer;
    try {
      r = await fetch(`/api/replay/${action}`, {
        method: "POST", headers, body: body ? JSON.stringify(body) : "",
      });
      answer = await r.json().catch(() => ({}));
    } catch (e) {
      el("replay-msg").textContent = `${action}: ${e.message}`;
      return;
    } finally {
      this.pending -= 1;
    }
    if (r.ok) {
      el("replay-msg").textContent = "";
      // Until the stream's next state, the page's state is from before the seek.
      if (action === "seek") this.afterSeek = true;
      this.show(answer);
    } else {
      if (r.status === 401) el("replay-token-box").hidden = false;
      el("replay-msg").textContent = answer.error || `${action}: HTTP ${r.status}`;
    }
  }
}
