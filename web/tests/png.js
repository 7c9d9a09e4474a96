// A tiny PNG decoder for the browser tests' screenshots (8-bit greyscale, grey +
// alpha, RGB or RGBA, not interlaced: what Chromium writes), and a colour count
// used to tell whether a screenshot shows the scene or only the UI around it.
import { inflateSync } from 'node:zlib';

const SIGNATURE = Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]);
const CHANNELS = { 0: 1, 2: 3, 4: 2, 6: 4 };

/** Decodes a PNG buffer into { width, height, rgba } (rgba: Uint8Array, 4 bytes a pixel). */
export function decodePng(buf) {
  if (!Buffer.isBuffer(buf) || buf.length < 8 || !buf.subarray(0, 8).equals(SIGNATURE)) throw new Error('not a PNG');
  let off = 8, width = 0, height = 0, depth = 0, type = -1, interlace = 0;
  const idat = [];
  while (off + 8 <= buf.length) {
    const len = buf.readUInt32BE(off);
    const kind = buf.toString('latin1', off + 4, off + 8);
    const data = buf.subarray(off + 8, off + 8 + len);
    if (kind === 'IHDR') {
      width = data.readUInt32BE(0); height = data.readUInt32BE(4);
      depth = data[8]; type = data[9]; interlace = data[12];
    } else if (kind === 'IDAT') idat.push(data);
    else if (kind === 'IEND') break;
    off += 12 + len;
  }
  const ch = CHANNELS[type];
  if (!width || !height || depth !== 8 || !ch || interlace !== 0) {
    throw new Error(`unsupported PNG (bit depth ${depth}, colour type ${type}, interlace ${interlace})`);
  }
  const raw = inflateSync(Buffer.concat(idat));
  const stride = width * ch;
  if (raw.length < height * (stride + 1)) throw new Error('truncated PNG data');
  const px = new Uint8Array(height * stride);
  for (let y = 0; y < height; y++) {
    const filter = raw[y * (stride + 1)];
    const src = y * (stride + 1) + 1, dst = y * stride, up = dst - stride;
    for (let i = 0; i < stride; i++) {
      const a = i >= ch ? px[dst + i - ch] : 0;
      const b = y > 0 ? px[up + i] : 0;
      const c = y > 0 && i >= ch ? px[up + i - ch] : 0;
      let v = raw[src + i];
      if (filter === 1) v += a;
      else if (filter === 2) v += b;
      else if (filter === 3) v += (a + b) >> 1;
      else if (filter === 4) {
        const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
        v += pa <= pb && pa <= pc ? a : (pb <= pc ? b : c);
      } else if (filter !== 0) throw new Error(`bad PNG filter ${filter} on row ${y}`);
      px[dst + i] = v & 0xff;
    }
  }
  const rgba = new Uint8Array(width * height * 4);
  for (let i = 0, j = 0; i < width * height; i++, j += ch) {
    const g = ch <= 2;
    rgba[i * 4] = px[j];
    rgba[i * 4 + 1] = g ? px[j] : px[j + 1];
    rgba[i * 4 + 2] = g ? px[j] : px[j + 2];
    rgba[i * 4 + 3] = ch === 2 ? px[j + 1] : (ch === 4 ? px[j + 3] : 255);
  }
  return { width, height, rgba };
}

/** Hue (degrees), saturation and value (0..1) of an 8-bit RGB colour. */
export function hsv(r, g, b) {
  const max = Math.max(r, g, b), min = Math.min(r, g, b), d = max - min;
  let h = 0;
  if (d > 0) {
    if (max === r) h = 60 * (((g - b) / d) % 6);
    else if (max === g) h = 60 * ((b - r) / d + 2);
    else h = 60 * ((r - g) / d + 4);
    if (h < 0) h += 360;
  }
  return { h, s: max === 0 ? 0 : d / max, v: max / 255 };
}

/** The blocks' colours as hue ranges (degrees) of saturated pixels. */
export const BLOCK_HUES = {
  red: [[345, 360], [0, 15]],
  yellow: [[40, 70]],
  green: [[90, 160]],
  blue: [[195, 250]],
};

/**
 * Counts the pixels of an image (from decodePng) in each of `hues`' classes:
 * saturated (s >= minS), not dark (v >= minV), hue inside one of the class's ranges.
 * Also returns the image's grey-level standard deviation (0 for a blank image).
 */
export function colourStats(img, { hues = BLOCK_HUES, minS = 0.35, minV = 0.3 } = {}) {
  const counts = Object.fromEntries(Object.keys(hues).map((k) => [k, 0]));
  const n = img.width * img.height;
  let sum = 0, sum2 = 0;
  for (let i = 0; i < n; i++) {
    const r = img.rgba[i * 4], g = img.rgba[i * 4 + 1], b = img.rgba[i * 4 + 2];
    const grey = 0.299 * r + 0.587 * g + 0.114 * b;
    sum += grey; sum2 += grey * grey;
    const c = hsv(r, g, b);
    if (c.s < minS || c.v < minV) continue;
    for (const [k, ranges] of Object.entries(hues)) {
      if (ranges.some(([lo, hi]) => c.h >= lo && c.h < hi)) { counts[k]++; break; }
    }
  }
  const mean = sum / n;
  return { counts, pixels: n, greyStd: Math.sqrt(Math.max(0, sum2 / n - mean * mean)) };
}

/**
 * Whether a screenshot's colourStats show the blocks (so a rerun viewer shows
 * the recording): the viewer's own UI has no red or yellow, and without a
 * recording there are no blocks. Red and yellow must each cover at least
 * 0.02 % of the pixels (one block in the 3-D view covers several thousand of a
 * 1500 x 1150 screenshot), and the image must not be blank.
 */
export function showsBlocks(stats) {
  const min = 0.0002 * stats.pixels;
  return stats.greyStd > 5 && stats.counts.red >= min && stats.counts.yellow >= min;
}
