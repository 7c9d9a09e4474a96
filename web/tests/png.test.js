// The screenshot checks of page.test.js, without a browser: the PNG decoder on
// PNGs written here with every filter type, and the "shows the blocks" test on
// synthetic images and on the committed rerun viewer screenshot.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { deflateSync } from 'node:zlib';
import { readFileSync, existsSync } from 'node:fs';
import { join, dirname, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { decodePng, colourStats, showsBlocks } from './png.js';

const root = resolve(dirname(fileURLToPath(import.meta.url)), '..', '..');

function crc32(buf) {
  let c = ~0;
  for (const b of buf) {
    c ^= b;
    for (let k = 0; k < 8; k++) c = (c >>> 1) ^ (0xedb88320 & -(c & 1));
  }
  return ~c >>> 0;
}

function chunk(kind, data) {
  const out = Buffer.alloc(12 + data.length);
  out.writeUInt32BE(data.length, 0);
  out.write(kind, 4, 'latin1');
  data.copy(out, 8);
  out.writeUInt32BE(crc32(out.subarray(4, 8 + data.length)), 8 + data.length);
  return out;
}

/** Encodes `px` (width * height * ch bytes) as a PNG, row y with filter filters[y % 5]. */
function encodePng(width, height, ch, px, filters = [0, 1, 2, 3, 4]) {
  const type = { 1: 0, 2: 4, 3: 2, 4: 6 }[ch];
  const stride = width * ch;
  const raw = Buffer.alloc(height * (stride + 1));
  for (let y = 0; y < height; y++) {
    const f = filters[y % filters.length];
    raw[y * (stride + 1)] = f;
    for (let i = 0; i < stride; i++) {
      const x = px[y * stride + i];
      const a = i >= ch ? px[y * stride + i - ch] : 0;
      const b = y > 0 ? px[(y - 1) * stride + i] : 0;
      const c = y > 0 && i >= ch ? px[(y - 1) * stride + i - ch] : 0;
      let pred = 0;
      if (f === 1) pred = a;
      else if (f === 2) pred = b;
      else if (f === 3) pred = (a + b) >> 1;
      else if (f === 4) {
        const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
        pred = pa <= pb && pa <= pc ? a : (pb <= pc ? b : c);
      }
      raw[y * (stride + 1) + 1 + i] = (x - pred) & 0xff;
    }
  }
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(width, 0); ihdr.writeUInt32BE(height, 4);
  ihdr[8] = 8; ihdr[9] = type; ihdr[10] = 0; ihdr[11] = 0; ihdr[12] = 0;
  return Buffer.concat([
    Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]),
    chunk('IHDR', ihdr),
    // Two IDAT chunks: the decoder must join them.
    ...(() => { const z = deflateSync(raw); const h = z.length >> 1; return [chunk('IDAT', z.subarray(0, h)), chunk('IDAT', z.subarray(h))]; })(),
    chunk('IEND', Buffer.alloc(0)),
  ]);
}

/** An RGB image of `w` x `h` grey UI (two shades) with `boxes` of colour drawn in. */
function image(w, h, boxes = []) {
  const px = new Uint8Array(w * h * 3);
  for (let y = 0; y < h; y++) for (let x = 0; x < w; x++) px.set((x >> 4) % 2 ? [240, 240, 242] : [200, 200, 206], (y * w + x) * 3);
  for (const { x0, y0, size, rgb } of boxes) {
    for (let y = y0; y < y0 + size; y++) for (let x = x0; x < x0 + size; x++) px.set(rgb, (y * w + x) * 3);
  }
  return px;
}

test('decodePng decodes every filter type and colour type', () => {
  for (const ch of [1, 2, 3, 4]) {
    const w = 13, h = 11;
    const px = new Uint8Array(w * h * ch);
    // Pseudo-random bytes, half of them from {0..3} so that Paeth's ties occur.
    let r = 12345;
    for (let i = 0; i < px.length; i++) { r = (r * 1103515245 + 12345) >>> 0; px[i] = (r >>> 16) & (i % 2 ? 0xff : 3); }
    const img = decodePng(encodePng(w, h, ch, px));
    assert.equal(img.width, w);
    assert.equal(img.height, h);
    for (let i = 0; i < w * h; i++) {
      const src = [...px.subarray(i * ch, i * ch + ch)];
      const want = ch === 1 ? [src[0], src[0], src[0], 255]
        : ch === 2 ? [src[0], src[0], src[0], src[1]]
          : ch === 3 ? [...src, 255] : src;
      assert.deepEqual([...img.rgba.subarray(i * 4, i * 4 + 4)], want, `pixel ${i}, ${ch} channels`);
    }
  }
});

test('decodePng refuses what is not an 8-bit PNG', () => {
  assert.throws(() => decodePng(Buffer.from('not a png at all')), /not a PNG/);
  const png = encodePng(2, 2, 3, new Uint8Array(12));
  png[8 + 8 + 8] = 16; // IHDR bit depth
  assert.throws(() => decodePng(png), /unsupported PNG/);
});

test('showsBlocks: grey UI and blue highlights are not the blocks; red and yellow blocks are', () => {
  const w = 300, h = 200;
  const stats = (boxes) => colourStats(decodePng(encodePng(w, h, 3, image(w, h, boxes))));
  assert.equal(showsBlocks(stats([])), false, 'grey UI');
  assert.equal(showsBlocks(stats([{ x0: 0, y0: 0, size: 60, rgb: [40, 110, 220] }])), false, 'blue selection');
  assert.equal(showsBlocks(colourStats(decodePng(encodePng(w, h, 3, new Uint8Array(w * h * 3))))), false, 'blank');
  const red = { x0: 10, y0: 10, size: 20, rgb: [255, 87, 89] };
  const yellow = { x0: 100, y0: 10, size: 20, rgb: [237, 201, 72] };
  // Shaded faces, as the 3-D view draws them.
  const darkRed = { x0: 10, y0: 100, size: 20, rgb: [150, 50, 52] };
  const darkYellow = { x0: 100, y0: 100, size: 20, rgb: [150, 128, 45] };
  assert.equal(showsBlocks(stats([red])), false, 'red alone');
  assert.equal(showsBlocks(stats([yellow])), false, 'yellow alone');
  assert.equal(showsBlocks(stats([red, yellow])), true, 'red and yellow blocks');
  assert.equal(showsBlocks(stats([darkRed, darkYellow])), true, 'shaded red and yellow blocks');
  assert.equal(showsBlocks(stats([{ ...red, size: 2 }, { ...yellow, size: 2 }])), false, 'a few stray pixels');
});

test('the committed rerun viewer screenshot shows the blocks, its UI panels do not', { skip: !existsSync(join(root, 'screenshots', 'rerun-viewer.png')) }, () => {
  const img = decodePng(readFileSync(join(root, 'screenshots', 'rerun-viewer.png')));
  assert.equal(showsBlocks(colourStats(img)), true, JSON.stringify(colourStats(img)));
  // The left panel (sources, blueprint tree): rerun's own UI.
  const w = Math.min(190, img.width), rgba = new Uint8Array(w * img.height * 4);
  for (let y = 0; y < img.height; y++) rgba.set(img.rgba.subarray(y * img.width * 4, (y * img.width + w) * 4), y * w * 4);
  const panel = colourStats({ width: w, height: img.height, rgba });
  assert.equal(panel.counts.red + panel.counts.yellow, 0, JSON.stringify(panel));
});
