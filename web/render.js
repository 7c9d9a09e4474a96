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

/** Draws layers onto a visible canvas: base image, optional heatmap, then marks. */
export function compose(canvas, n, base, heat, opacity, marks) {
  const ctx = canvas.getContext('2d');
  const W = canvas.width, s = W / n;
  ctx.imageSmoothingEnabled = false;
  ctx.clearRect(0, 0, W, W);
  if (base) ctx.drawImage(base, 0, 0, W, W);
  if (heat) { ctx.globalAlpha = opacity; ctx.drawImage(heat, 0, 0, W, W); ctx.globalAlpha = 1; }
  for (const m of marks) {
    if (m.kind === 'arrow') arrow(ctx, s, m.from, m.to, m.color, m.label);
    else if (m.kind === 'point') point(ctx, s, m.at, m.color, m.label, m.ring, m.below);
    else if (m.kind === 'gripper') gripper(ctx, s, m);
  }
}

// The gripper's footprint at pixel m.at: two fingers m.jaw pixels apart along
// the closing direction of yaw m.yaw (radians; pixel x and y follow world x and
// y), each m.finger pixels long across it.
function gripper(ctx, s, m) {
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
  if (m.label) tag(ctx, x + 14, y - 14, m.label, m.color);
}

function px(s, p) { return [(p.x + 0.5) * s, (p.y + 0.5) * s]; }

function point(ctx, s, at, color, label, ring, below) {
  const [x, y] = px(s, at);
  ctx.lineWidth = 3; ctx.strokeStyle = '#000a';
  ctx.beginPath(); ctx.arc(x, y, ring ? 11 : 7, 0, 2 * Math.PI); ctx.stroke();
  ctx.lineWidth = 2; ctx.strokeStyle = color;
  ctx.beginPath(); ctx.arc(x, y, ring ? 11 : 7, 0, 2 * Math.PI); ctx.stroke();
  if (label) tag(ctx, x + 12, below ? y + 26 : y - 10, label, color);
}

function arrow(ctx, s, from, to, color, label) {
  const [x0, y0] = px(s, from), [x1, y1] = px(s, to);
  const len = Math.hypot(x1 - x0, y1 - y0);
  for (const [w, c] of [[5, '#000b'], [2.5, color]]) {
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
  if (label) tag(ctx, (x0 + x1) / 2 + 8, (y0 + y1) / 2 - 8, label, color);
}

function tag(ctx, x, y, text, color) {
  ctx.font = '600 12px ui-sans-serif, system-ui, sans-serif';
  const w = ctx.measureText(text).width + 8;
  x = Math.min(Math.max(2, x), ctx.canvas.width - w - 2); y = Math.min(Math.max(16, y), ctx.canvas.height - 4);
  ctx.fillStyle = '#000c'; ctx.fillRect(x, y - 13, w, 17);
  ctx.fillStyle = color; ctx.fillText(text, x + 4, y);
}

/** Canvas click -> heightmap pixel (y, x). */
export function pixelAt(canvas, n, ev) {
  const r = canvas.getBoundingClientRect();
  const x = Math.floor(((ev.clientX - r.left) / r.width) * n);
  const y = Math.floor(((ev.clientY - r.top) / r.height) * n);
  return { y: Math.min(n - 1, Math.max(0, y)), x: Math.min(n - 1, Math.max(0, x)) };
}
