// Decoding and drawing: base64 payloads from the server, colormaps, canvas overlays.

/** Base64 -> Uint8Array. */
export function b64bytes(s) {
  const bin = atob(s);
  const out = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
  return out;
}

/** Base64 of little-endian f32 -> Float32Array. */
export function b64f32(s) {
  const b = b64bytes(s);
  return new Float32Array(b.buffer, b.byteOffset, b.byteLength / 4);
}

// Turbo colormap (Google, Apache-2.0), polynomial approximation.
function turbo(t) {
  t = Math.min(1, Math.max(0, t));
  const r = 0.13572138 + t * (4.6153926 + t * (-42.66032258 + t * (132.13108234 + t * (-152.94239396 + t * 59.28637943))));
  const g = 0.09140261 + t * (2.19418839 + t * (4.84296658 + t * (-14.18503333 + t * (4.27729857 + t * 2.82956604))));
  const b = 0.1066733 + t * (12.64194608 + t * (-60.58204836 + t * (110.36276771 + t * (-89.90310912 + t * 27.34824973))));
  return [r * 255, g * 255, b * 255];
}

function viridisLike(t) {
  t = Math.min(1, Math.max(0, t));
  return [68 + t * (253 - 68), 1 + t * (231 - 1), 84 + t * (37 - 84) + Math.sin(t * Math.PI) * 80];
}

/** An offscreen n x n canvas holding RGB bytes. */
export function rgbCanvas(rgb, n) {
  const c = new OffscreenCanvas(n, n);
  const ctx = c.getContext('2d');
  const img = ctx.createImageData(n, n);
  for (let i = 0; i < n * n; i++) {
    img.data[4 * i] = rgb[3 * i]; img.data[4 * i + 1] = rgb[3 * i + 1]; img.data[4 * i + 2] = rgb[3 * i + 2]; img.data[4 * i + 3] = 255;
  }
  ctx.putImageData(img, 0, 0);
  return c;
}

/** Heights (metres) as an offscreen canvas, 0 .. 0.2 m colour-mapped. */
export function depthCanvas(depth, n) {
  const c = new OffscreenCanvas(n, n);
  const ctx = c.getContext('2d');
  const img = ctx.createImageData(n, n);
  for (let i = 0; i < n * n; i++) {
    const [r, g, b] = viridisLike(depth[i] / 0.2);
    img.data[4 * i] = r; img.data[4 * i + 1] = g; img.data[4 * i + 2] = b; img.data[4 * i + 3] = 255;
  }
  ctx.putImageData(img, 0, 0);
  return c;
}

/** A distance map as a Turbo heatmap (near = dark blue, far = red); masked
 *  (non-finite) pixels transparent. Returns the canvas and the finite range. */
export function heatCanvas(map, n) {
  let lo = Infinity, hi = -Infinity;
  for (const v of map) if (Number.isFinite(v)) { if (v < lo) lo = v; if (v > hi) hi = v; }
  const c = new OffscreenCanvas(n, n);
  const ctx = c.getContext('2d');
  const img = ctx.createImageData(n, n);
  const span = hi > lo ? hi - lo : 1;
  for (let i = 0; i < n * n; i++) {
    const v = map[i];
    if (!Number.isFinite(v)) continue;
    const [r, g, b] = turbo((v - lo) / span);
    img.data[4 * i] = r; img.data[4 * i + 1] = g; img.data[4 * i + 2] = b; img.data[4 * i + 3] = 255;
  }
  ctx.putImageData(img, 0, 0);
  return { canvas: c, lo, hi };
}

/** Draws layers onto a visible canvas: base image, optional heatmap, then
 *  marks, then the marks' labels, placed so that no two overlap and none
 *  leaves the canvas. The canvas is sized to its displayed size (times the
 *  device pixel ratio) so that marks and labels are sharp; coordinates are
 *  CSS pixels from the canvas's top left. Returns the canvas's size and the
 *  labels as drawn: `{ width, height, labels: [{ text, x, y, w, h, ax, ay }] }`
 *  (each label's rectangle and the anchor it labels). */
export function compose(canvas, n, base, heat, opacity, marks) {
  const ctx = canvas.getContext('2d');
  const cssW = canvas.clientWidth, cssH = canvas.clientHeight;
  const dpr = window.devicePixelRatio || 1;
  if (cssW > 0 && cssH > 0) {
    const bw = Math.round(cssW * dpr), bh = Math.round(cssH * dpr);
    if (canvas.width !== bw || canvas.height !== bh) { canvas.width = bw; canvas.height = bh; }
  }
  // Drawing units: CSS pixels (or the canvas's own, while it is not shown).
  const u = cssW > 0 ? canvas.width / cssW : 1;
  ctx.setTransform(u, 0, 0, u, 0, 0);
  const W = canvas.width / u, H = canvas.height / u, s = W / n;
  ctx.imageSmoothingEnabled = false;
  ctx.clearRect(0, 0, W, H);
  if (base) ctx.drawImage(base, 0, 0, W, W);
  if (heat) { ctx.globalAlpha = opacity; ctx.drawImage(heat, 0, 0, W, W); ctx.globalAlpha = 1; }
  const wanted = [], keepClear = [];
  for (const m of marks) {
    if (m.kind === 'arrow') arrow(ctx, s, m, wanted, keepClear);
    else if (m.kind === 'point') point(ctx, s, m, wanted, keepClear);
    else if (m.kind === 'gripper') gripper(ctx, s, m, wanted, keepClear);
    else if (m.kind === 'target') target(ctx, s, m, wanted, keepClear);
  }
  const labels = drawLabels(ctx, wanted, keepClear, W, H);
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  return { width: W, height: H, labels };
}

// A right action's place (the simulator's truth): a block's square of m.size
// pixels at m.at, turned by m.yaw, shaded when m.filled, else outlined.
function target(ctx, s, m, wanted, keepClear) {
  const [x, y] = px(s, m.at);
  const h = (m.size / 2) * s;
  ctx.save();
  ctx.translate(x, y);
  ctx.rotate(m.yaw);
  if (m.filled) { ctx.globalAlpha = 0.45; ctx.fillStyle = m.color; ctx.fillRect(-h, -h, 2 * h, 2 * h); ctx.globalAlpha = 1; }
  ctx.lineWidth = 2; ctx.strokeStyle = m.color;
  if (!m.filled) ctx.setLineDash([4, 3]);
  ctx.strokeRect(-h, -h, 2 * h, 2 * h);
  ctx.restore();
  keepClear.push({ x: x - h, y: y - h, w: 2 * h, h: 2 * h });
  if (m.label) wanted.push({ text: m.label, color: m.color, ax: x, ay: y, r: h * 1.42 + 2, below: m.below });
}

// The gripper's footprint at pixel m.at: two fingers m.jaw pixels apart along
// the closing direction of yaw m.yaw (radians; pixel x and y follow world x and
// y), each m.finger pixels long across it.
function gripper(ctx, s, m, wanted, keepClear) {
  const [x, y] = px(s, m.at);
  const c = Math.cos(m.yaw), sn = Math.sin(m.yaw);
  const half = (m.jaw / 2) * s, len = (m.finger / 2) * s;
  for (const [w, col] of [[6, '#000b'], [3, m.color]]) {
    ctx.lineWidth = w; ctx.strokeStyle = col;
    for (const side of [-1, 1]) {
      const fx = x + side * half * c, fy = y + side * half * sn;
      ctx.beginPath();
      ctx.moveTo(fx - len * -sn, fy - len * c);
      ctx.lineTo(fx + len * -sn, fy + len * c);
      ctx.stroke();
    }
    ctx.beginPath(); ctx.moveTo(x - half * c, y - half * sn); ctx.lineTo(x + half * c, y + half * sn); ctx.stroke();
  }
  const r = Math.max(half, len) + 4;
  keepClear.push({ x: x - r, y: y - r, w: 2 * r, h: 2 * r });
  if (m.label) wanted.push({ text: m.label, color: m.color, ax: x, ay: y, r });
}

function px(s, p) { return [(p.x + 0.5) * s, (p.y + 0.5) * s]; }

function point(ctx, s, m, wanted, keepClear) {
  const [x, y] = px(s, m.at);
  const r = m.ring ? 11 : 7;
  ctx.lineWidth = 3; ctx.strokeStyle = '#000a';
  ctx.beginPath(); ctx.arc(x, y, r, 0, 2 * Math.PI); ctx.stroke();
  ctx.lineWidth = 2; ctx.strokeStyle = m.color;
  ctx.beginPath(); ctx.arc(x, y, r, 0, 2 * Math.PI); ctx.stroke();
  keepClear.push({ x: x - r - 2, y: y - r - 2, w: 2 * r + 4, h: 2 * r + 4 });
  if (m.label) wanted.push({ text: m.label, color: m.color, ax: x, ay: y, r: r + 2, below: m.below });
}

function arrow(ctx, s, m, wanted, keepClear) {
  const [x0, y0] = px(s, m.from), [x1, y1] = px(s, m.to);
  const len = Math.hypot(x1 - x0, y1 - y0);
  for (const [w, c] of [[5, '#000b'], [2.5, m.color]]) {
    ctx.lineWidth = w; ctx.strokeStyle = c; ctx.fillStyle = c;
    ctx.beginPath(); ctx.moveTo(x0, y0); ctx.lineTo(x1, y1); ctx.stroke();
    if (len > 4) {
      const a = Math.atan2(y1 - y0, x1 - x0), h = 12 + w;
      ctx.beginPath(); ctx.moveTo(x1, y1);
      ctx.lineTo(x1 - h * Math.cos(a - 0.4), y1 - h * Math.sin(a - 0.4));
      ctx.lineTo(x1 - h * Math.cos(a + 0.4), y1 - h * Math.sin(a + 0.4));
      ctx.closePath(); ctx.fill();
    }
  }
  // The shaft, as small squares a label had better not cover.
  const k = Math.max(1, Math.ceil(len / 12));
  for (let i = 0; i <= k; i++) {
    const x = x0 + ((x1 - x0) * i) / k, y = y0 + ((y1 - y0) * i) / k;
    keepClear.push({ x: x - 4, y: y - 4, w: 8, h: 8 });
  }
  if (m.label) wanted.push({ text: m.label, color: m.color, ax: (x0 + x1) / 2, ay: (y0 + y1) / 2, r: 6 });
}

function overlap(a, b) {
  const w = Math.min(a.x + a.w, b.x + b.w) - Math.max(a.x, b.x);
  const h = Math.min(a.y + a.h, b.y + b.h) - Math.max(a.y, b.y);
  return w > 0 && h > 0 ? w * h : 0;
}

/** Where a w x h label of anchor (ax, ay), kept r clear of it, may go: beside
 *  the anchor in eight directions (the preferred first), then further out. */
function* spots(l, w, h, W, H) {
  const dirs = l.below
    ? [[1, 1], [-1, 1], [0, 1], [1, 0], [-1, 0], [1, -1], [-1, -1], [0, -1]]
    : [[1, -1], [1, 1], [-1, -1], [-1, 1], [0, -1], [0, 1], [1, 0], [-1, 0]];
  const step = h + 4;
  for (let k = 0; k < 40; k++) {
    const g = l.r + 3 + k * step;
    for (const [dx, dy] of dirs) {
      const d = dx && dy ? g * 0.75 : g;
      const x = dx > 0 ? l.ax + d : dx < 0 ? l.ax - d - w : l.ax - w / 2;
      const y = dy > 0 ? l.ay + d : dy < 0 ? l.ay - d - h : l.ay - h / 2;
      yield { x: Math.min(Math.max(1, x), W - w - 1), y: Math.min(Math.max(1, y), H - h - 1), k };
    }
  }
}

/** Places and draws the labels, in order: each at the first spot that covers
 *  no label placed before it (a hard rule) and, if it can, no mark. */
function drawLabels(ctx, wanted, keepClear, W, H) {
  const fontPx = 12, pad = 4;
  ctx.font = `600 ${fontPx}px ui-sans-serif, system-ui, sans-serif`;
  const h = fontPx + 6;
  const placed = [];
  for (const l of wanted) {
    const w = Math.min(W - 2, Math.ceil(ctx.measureText(l.text).width + 2 * pad));
    let best = null, bestCost = Infinity;
    for (const c of spots(l, w, h, W, H)) {
      const rect = { x: c.x, y: c.y, w, h };
      if (placed.some((p) => overlap(p, rect) > 0)) continue;
      // Covering marks costs; so does going far from the anchor.
      const cover = keepClear.reduce((a, o) => a + overlap(o, rect), 0);
      const cost = cover + c.k * 40;
      if (cost < bestCost) { best = rect; bestCost = cost; }
      if (cover === 0) break;
    }
    if (!best) best = { x: Math.min(Math.max(1, l.ax), W - w - 1), y: Math.min(Math.max(1, l.ay), H - h - 1), w, h };
    placed.push({ text: l.text, ...best, ax: l.ax, ay: l.ay, color: l.color, r: l.r });
  }
  for (const p of placed) {
    // A leader line when the label had to move away from its mark.
    const nx = Math.min(Math.max(p.ax, p.x), p.x + p.w), ny = Math.min(Math.max(p.ay, p.y), p.y + p.h);
    const far = Math.hypot(nx - p.ax, ny - p.ay);
    if (far > p.r + 8) {
      const ux = (nx - p.ax) / far, uy = (ny - p.ay) / far;
      for (const [lw, col] of [[3, '#000b'], [1.25, p.color]]) {
        ctx.lineWidth = lw; ctx.strokeStyle = col;
        ctx.beginPath(); ctx.moveTo(p.ax + ux * p.r, p.ay + uy * p.r); ctx.lineTo(nx, ny); ctx.stroke();
      }
    }
  }
  for (const p of placed) {
    ctx.fillStyle = '#000c'; ctx.fillRect(p.x, p.y, p.w, p.h);
    ctx.fillStyle = p.color; ctx.textBaseline = 'middle';
    ctx.fillText(p.text, p.x + pad, p.y + p.h / 2 + 0.5);
  }
  ctx.textBaseline = 'alphabetic';
  return placed.map(({ text, x, y, w, h: hh, ax, ay }) => ({ text, x, y, w, h: hh, ax, ay }));
}

/** Canvas click -> heightmap pixel (y, x). */
export function pixelAt(canvas, n, ev) {
  const r = canvas.getBoundingClientRect();
  const x = Math.floor(((ev.clientX - r.left) / r.width) * n);
  const y = Math.floor(((ev.clientY - r.top) / r.height) * n);
  return { y: Math.min(n - 1, Math.max(0, y)), x: Math.min(n - 1, Math.max(0, x)) };
}

// The simulator's verdict on a pair's F (documents.rs `PairDoc.truth`): ✓ or ✗
// in a table's cell, in words in its tooltip and beside the chosen pair.
const VERDICT_SHORT = { right: '✓', wrong_block: '✗', miss: '✗', no_progress: '✗', reversal: '✗', out: '✗' };
const VERDICT_WORDS = { right: 'right', wrong_block: 'wrong (wrong block)', miss: 'wrong (a miss)', no_progress: 'wrong (no progress)', reversal: 'wrong (a reversal)', out: 'wrong (out of the workspace)' };
export function truthCell(p) {
  if (!p.truth) return p.matched ? '–' : '…';
  return VERDICT_SHORT[p.truth.verdict] || p.truth.verdict;
}
export function truthWords(t) {
  const far = t.verdict !== 'right' && t.distance_mm != null ? `; ${t.distance_mm.toFixed(0)} mm from a right action` : '';
  return `${VERDICT_WORDS[t.verdict] || t.verdict}: ${t.why}${far}`;
}
