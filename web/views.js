// The robots' camera views from /api/views/stream: the newest view of each robot camera, its
// JPEG decoded when first asked for. The stream is open only while a robot is chosen: a view
// is a JPEG of up to 32 kB, a few a second per camera, not worth carrying to a page that does
// not show it. On connect the server sends every view it keeps, then each new one.
//
// In a replay the server feeds the log's views at the replay clock and, after a seek,
// re-sends each camera's newest view at or before the new time; the page drops what it holds
// from after that time itself (`forgetAfter`), so a seek back shows no view from the future.

/// Reconnection delays grow from the first to the last (as the live stream's).
const RETRY_MS = [250, 500, 1000, 2000, 4000];
export const CAMERAS = ["left", "right"];

export const viewKey = (robotId, camera) => `${robotId}/${camera}`;

/// A view as kept: the message and its image, decoded on demand.
function entryOf(view) {
  return { view, image: null, loaded: false, failed: false };
}

function decode(e) {
  if (e.image) return;
  e.image = new Image();
  e.image.onload = () => { e.loaded = true; };
  e.image.onerror = () => { e.failed = true; };
  e.image.src = `data:image/jpeg;base64,${e.view.jpeg_base64}`;
}

export class ViewStream {
  constructor() {
    /// Per robot camera: `latest` (the newest view come) and `shown` (the newest decoded).
    this.cameras = new Map();
    this.state = "off";
    this.wanted = false;
    this.ws = null;
    this.retries = 0;
    this.retryTimer = null;
    this.received = 0;
  }

  /// Opens the stream (true) or closes it and forgets every view (false).
  want(on) {
    if (on === this.wanted) return;
    this.wanted = on;
    if (on) {
      this.connect();
      return;
    }
    clearTimeout(this.retryTimer);
    const ws = this.ws;
    this.ws = null;
    if (ws) {
      ws.onmessage = null;
      // Closing one still connecting makes the browser log an error: close it once open.
      if (ws.readyState === WebSocket.CONNECTING) ws.onopen = () => ws.close();
      else ws.close();
    }
    this.cameras.clear();
    this.state = "off";
  }

  connect() {
    const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/api/views/stream`);
    this.ws = ws;
    this.state = "connecting";
    ws.onopen = () => {
      this.retries = 0;
      this.state = "live";
    };
    ws.onmessage = (m) => {
      try {
        this.add(JSON.parse(m.data));
      } catch (e) {
        console.warn("a camera view the page could not read", e);
      }
    };
    ws.onclose = () => {
      if (this.ws !== ws) return;
      const wait = RETRY_MS[Math.min(this.retries, RETRY_MS.length - 1)];
      this.retries += 1;
      this.state = "down";
      this.retryTimer = setTimeout(() => this.wanted && this.connect(), wait);
    };
  }

  add(view) {
    if (typeof view.robot_id !== "string" || !CAMERAS.includes(view.camera) || !Array.isArray(view.candidates)) {
      throw new Error("not a camera view");
    }
    const key = viewKey(view.robot_id, view.camera);
    const kept = this.cameras.get(key);
    this.received += 1;
    // The arrival order is the server's: a re-sent older view after a seek replaces a newer one.
    if (kept) kept.latest = entryOf(view);
    else this.cameras.set(key, { latest: entryOf(view), shown: null });
  }

  /// Drops what came from after `stamp` (ns): a replay moved back in time.
  forgetAfter(stamp) {
    for (const [key, c] of this.cameras) {
      if (c.latest.view.stamp > stamp) this.cameras.delete(key);
      else if (c.shown && c.shown.view.stamp > stamp) c.shown = null;
    }
  }

  /// The newest view of a robot camera whose image is ready to draw (a newer one decodes
  /// meanwhile), or null. `pending`: a view came but its image is not decoded yet.
  ready(robotId, camera) {
    const c = this.cameras.get(viewKey(robotId, camera));
    if (!c) return { shown: null, pending: false };
    decode(c.latest);
    if (c.latest.loaded || c.latest.failed) c.shown = c.latest;
    return { shown: c.shown, pending: c.shown !== c.latest };
  }

  /// Every robot camera kept: key → the latest view (metadata only) for the debug snapshot.
  summary() {
    const out = {};
    for (const [key, c] of this.cameras) {
      const v = c.latest.view;
      out[key] = { stamp: v.stamp, seq: v.seq, candidates: v.candidates.length,
        ball: v.candidates.some((k) => k.outcome === "ball") };
    }
    return out;
  }

  /// Whether any view of this robot is kept.
  has(robotId) {
    return CAMERAS.some((cam) => this.cameras.has(viewKey(robotId, cam)));
  }
}
