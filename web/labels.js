// Text labels on the pitch that must not cover each other or the marks they name (the
// intercept and the stop point often sit on the ball). Each label tries a few places around
// its anchor and takes the first one clear of the boxes kept before it; when none is clear,
// the one that covers least. Pure: sizes in, boxes out (CSS pixels, top-left origin).

/// How far a label keeps from its anchor, px.
const GAP_PX = 8;

/// Whether two boxes { x, y, w, h } overlap.
export function overlaps(a, b) {
  return a.x < b.x + b.w && b.x < a.x + a.w && a.y < b.y + b.h && b.y < a.y + a.h;
}

function overlapArea(a, b) {
  const w = Math.min(a.x + a.w, b.x + b.w) - Math.max(a.x, b.x);
  const h = Math.min(a.y + a.h, b.y + b.h) - Math.max(a.y, b.y);
  return w > 0 && h > 0 ? w * h : 0;
}

/// Places beside an anchor (x, y) for a label of w × h, in order of preference: right of it
/// just below, right just above, left below, left above, then rows further out each way,
/// then the same further to each side.
function spots(x, y, w, h) {
  const out = [];
  for (const far of [0, 1, 2]) {
    const left = [x + GAP_PX + far * (w + GAP_PX), x - GAP_PX - w - far * (w + GAP_PX)];
    const top = [y + 2, y - 2 - h, y + 4 + h, y - 4 - 2 * h, y + 6 + 2 * h, y - 6 - 3 * h,
      y + 8 + 3 * h, y - 8 - 4 * h];
    for (const t of top) for (const l of left) out.push({ x: l, y: t, w, h });
  }
  return out;
}

/// How much worse covering a kept box is than covering a plain mark: a label over another
/// label or over a box marked `keep` (the ball) hides what a person reads.
const KEEP_WEIGHT = 8;

export class LabelLayout {
  /// `bounds`: the box labels stay inside (the canvas), or null.
  constructor(bounds = null) {
    this.bounds = bounds;
    this.boxes = [];
  }

  /// A mark or a label drawn already: later labels keep off it (`keep`: at almost any cost,
  /// as off the ball).
  block(box, keep = false) {
    this.boxes.push({ ...box, weight: keep ? KEEP_WEIGHT : 1 });
  }

  /// A w × h label for the anchor (x, y): its box, kept as taken.
  place(x, y, w, h) {
    let best = null;
    for (const s of spots(x, y, w, h)) {
      const inside = !this.bounds || (s.x >= this.bounds.x && s.y >= this.bounds.y &&
        s.x + s.w <= this.bounds.x + this.bounds.w && s.y + s.h <= this.bounds.y + this.bounds.h);
      const covered = this.boxes.reduce((sum, b) => sum + b.weight * overlapArea(s, b), 0) +
        (inside ? 0 : KEEP_WEIGHT * w * h);
      if (!best || covered < best.covered) best = { box: s, covered };
      if (covered === 0) break;
    }
    this.boxes.push({ ...best.box, weight: KEEP_WEIGHT });
    return best.box;
  }
}
