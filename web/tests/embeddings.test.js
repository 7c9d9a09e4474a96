// The page on See-SPOT-Run with a user's own embedding network (ONNX) in
// headless Chromium: `view --embeddings models/embeddings/raw-patches.onnx`,
// the shipped example: one model (M = 1, so a decision has 1 policy x 2 demos
// = 2 pairs), feature depth D = 100 (the SPOT-Q policies' is 64), named
// `raw-patches` (the policy column names it, where the shipped policies show
// task names). Steps to a decision and checks the pairs table, click-to-query
// and the embedding (PCA) colours; the screenshot embeddings.png goes where
// page.test.js puts its screenshots ($SEESPOT_SCREENSHOTS, else a new
// temporary folder).
//
// Server: $SEESPOT_BIN (default ../target/release/seespot).
// SEESPOT_WEB_FROM_DISK=1 serves web/'s files from disk (the binary embeds the
// ones it was built with; serve.js `pageFromDisk`).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { mkdtempSync, mkdirSync, existsSync, readFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';
import { root, BIN, openView } from './serve.js';

const shots = process.env.SEESPOT_SCREENSHOTS
  ? resolve(process.env.SEESPOT_SCREENSHOTS)
  : mkdtempSync(join(tmpdir(), 'seespot-screenshots-'));
const RES = Number(process.env.SEESPOT_TEST_RESOLUTION || 224);
const MODEL = join('models', 'embeddings', 'raw-patches.onnx');
const NAME = 'raw-patches';

let view, page, pageUrl, stepAndWait;

before(async () => {
  assert.ok(existsSync(BIN), `no server binary at ${BIN}; build it with cargo build --release`);
  mkdirSync(shots, { recursive: true });
  view = await openView(['view', '--port', '0', '--no-viewer', '--task', 'stack', '--seed', '1',
    '--resolution', String(RES), '--embeddings', MODEL]);
  ({ page, pageUrl, stepAndWait } = view);
});

after(async () => {
  if (view) await view.close();
});

const api = async (path) => (await fetch(new URL(path, pageUrl))).json();

/** The pairs table's rows that show a (policy, demo) pair (not its placeholder row). */
const pairRows = () => page.$$eval('[data-testid=pairs] tbody tr[data-pair]', (trs) => trs.map((tr) => ({
  cells: [...tr.children].map((td) => td.textContent), chosen: tr.classList.contains('chosen'),
})));

/** The dimensions of the ONNX file's initializers, name -> dims: a minimal
 *  protobuf walk (ModelProto.graph = 7, GraphProto.initializer = 5,
 *  TensorProto.dims = 1, TensorProto.name = 8). */
function onnxInitializerDims(buf) {
  const varint = (b, at) => {
    let v = 0n, shift = 0n, i = at;
    for (;;) { const x = b[i++]; v |= BigInt(x & 0x7f) << shift; shift += 7n; if (!(x & 0x80)) break; }
    return [v, i];
  };
  /** The message's fields: [number, wire type, value (a BigInt or a bytes view)]. */
  const fields = (b) => {
    const out = [];
    for (let i = 0; i < b.length;) {
      let key, v;
      [key, i] = varint(b, i);
      const no = Number(key >> 3n), wt = Number(key & 7n);
      if (wt === 0) { [v, i] = varint(b, i); out.push([no, wt, v]); }
      else if (wt === 2) { let n; [n, i] = varint(b, i); out.push([no, wt, b.subarray(i, i + Number(n))]); i += Number(n); }
      else if (wt === 1) { out.push([no, wt, null]); i += 8; }
      else if (wt === 5) { out.push([no, wt, null]); i += 4; }
      else throw new Error(`unexpected protobuf wire type ${wt}`);
    }
    return out;
  };
  const dims = new Map();
  for (const [no, wt, graph] of fields(buf)) {
    if (no !== 7 || wt !== 2) continue;
    for (const [gno, gwt, tensor] of fields(graph)) {
      if (gno !== 5 || gwt !== 2) continue;
      let name = '';
      const d = [];
      for (const [tno, twt, v] of fields(tensor)) {
        if (tno === 8 && twt === 2) name = Buffer.from(v).toString('utf8');
        else if (tno === 1 && twt === 0) d.push(Number(v));
        else if (tno === 1 && twt === 2) for (let i = 0; i < v.length;) { let x; [x, i] = varint(v, i); d.push(Number(x)); }
      }
      dims.set(name, d);
    }
  }
  return dims;
}

test('the shipped example model has feature depth D = 100 (not the SPOT-Q policies\' 64)', () => {
  // Its one Conv makes the features: D output channels of 5 x 5 patches of
  // colour and depth (4 channels).
  const dims = onnxInitializerDims(readFileSync(join(root, MODEL)));
  assert.deepEqual(dims.get('patch.weight'), [100, 4, 5, 5], JSON.stringify([...dims]));
});

test('a decision on the ONNX model shows its 2 pairs, each naming the model', async () => {
  const s0 = await api('/api/state');
  assert.deepEqual(s0.policies, [NAME]);
  // The click-to-query's policy box offers the one model, by name.
  const options = await page.$$eval('[data-testid=query-policy] option', (os) => os.map((o) => [o.value, o.textContent]));
  assert.deepEqual(options, [['0', NAME]]);

  await stepAndWait('next-phase');
  assert.equal((await api('/api/state')).phase, 'embed');
  const d = await api('/api/decision');
  assert.ok(d, 'the decider gave no explanation record');
  assert.equal(d.pairs.length, 2, '1 model x 2 demos');
  assert.deepEqual(d.pairs.map((p) => p.policy), [NAME, NAME]);
  assert.deepEqual(d.pairs.map((p) => p.demo).sort(), [0, 1]);
  let rows = await pairRows();
  assert.equal(rows.length, 2, 'pair rows in the table');
  rows.forEach((r, i) => {
    assert.equal(r.cells[1], NAME, `policy of pair ${i}`);
    assert.equal(r.cells[2], `${d.pairs[i].demo}·${d.pairs[i].demo_step}`, `demo of pair ${i}`);
  });
  // No placeholder row beside them.
  assert.equal(await page.locator('[data-testid=pairs] tbody tr').count(), 2);

  // Match, then verify: L, C and each method's pick, as in the record.
  await stepAndWait('next-phase');
  assert.match(await page.getByTestId('overlay-label').textContent(), new RegExp(`match distance, ${NAME} \\(r\\d+\\)`));
  await stepAndWait('next-phase');
  assert.equal((await api('/api/state')).phase, 'verify');
  rows = await pairRows();
  rows.forEach((r, i) => {
    assert.equal(r.cells[1], NAME, `policy of pair ${i}`);
    assert.equal(r.cells[3], d.pairs[i].l.toFixed(3), `L of pair ${i}`);
    assert.equal(r.cells[4], d.pairs[i].c.toFixed(1), `C of pair ${i}`);
    assert.equal(r.cells[6].includes('CCD'), i === d.ccd_choice, `CCD mark on pair ${i}`);
    assert.equal(r.cells[6].includes('L2CD'), i === d.l2cd_choice, `L2CD mark on pair ${i}`);
  });
  assert.ok(rows.every((r) => !r.chosen));
  const said = await page.getByTestId('method-choices').textContent();
  const a = d.pairs[d.ccd_choice].matched, b = d.pairs[d.l2cd_choice].matched;
  assert.ok(said.includes(`CCD would take ${a.primitive} r${a.rotation} (${a.y}, ${a.x})`), said);
  assert.ok(said.includes(`L2CD would take ${b.primitive} r${b.rotation} (${b.y}, ${b.x})`), said);

  // Act: the chosen pair is marked and shown, and its action executed.
  await stepAndWait('next-phase');
  const s = await api('/api/state');
  assert.equal(s.phase, 'act');
  rows = await pairRows();
  assert.deepEqual(rows.map((r) => r.chosen), d.pairs.map((_, i) => i === d.chosen));
  assert.deepEqual(s.steps[0].action, d.action);
  assert.equal(await page.evaluate(() => window.seespot.frame.pair), d.chosen);
  assert.match(await page.getByTestId('demo-title').textContent(), new RegExp(`· policy ${NAME}$`));
  assert.deepEqual(view.errors, []);
  assert.deepEqual(await page.evaluate(() => window.seespot.errors), []);
});

test('click-to-query draws the model\'s distance map the backend computes', async () => {
  const f = await page.evaluate(() => window.seespot.frame);
  const a = f.demo.action;
  await page.getByTestId('query-policy').selectOption('0');
  const box = await page.getByTestId('demo-canvas').boundingBox();
  const n = f.resolution;
  await page.mouse.click(box.x + (a.x + 0.5) * box.width / n, box.y + (a.y + 0.5) * box.height / n);
  await page.waitForFunction(() => window.seespot.lastQuery, null, { timeout: 60_000 });
  const q = await page.evaluate(() => window.seespot.lastQuery);
  assert.deepEqual([q.y, q.x, q.policy, q.policy_name, q.pair], [a.y, a.x, 0, NAME, f.pair]);
  // One distance per live pixel, some of them finite.
  const map = new Float32Array(Uint8Array.from(Buffer.from(q.map, 'base64')).buffer);
  assert.equal(map.length, n * n);
  assert.ok(map.some(Number.isFinite));
  assert.ok(q.best, 'no nearest live pixel');
  // The same query from a second socket (a second client) gives the same map;
  // a second policy does not exist (M = 1) and is refused.
  const [again, refused] = await page.evaluate(({ pair, y, x }) => new Promise((ok) => {
    const ws = new WebSocket(`ws://${location.host}/ws`);
    const got = [];
    ws.onopen = () => {
      ws.send(JSON.stringify({ type: 'query', pair, policy: 0, y, x }));
      ws.send(JSON.stringify({ type: 'query', pair, policy: 1, y, x }));
    };
    ws.onmessage = (ev) => {
      const m = JSON.parse(ev.data);
      if (m.type === 'query' || m.type === 'error') got.push(m);
      if (got.length === 2) { ws.close(); ok(got); }
    };
  }), { pair: f.pair, y: a.y, x: a.x });
  assert.equal(again.type, 'query', JSON.stringify(again).slice(0, 300));
  assert.equal(again.map, q.map);
  assert.deepEqual(again.best, q.best);
  assert.equal(refused.type, 'error');
  assert.match(refused.message, /no policy 1/);
  assert.match(await page.getByTestId('query-result').textContent(),
    new RegExp(`under ${NAME}: nearest live pixel \\(${q.best.y}, ${q.best.x}\\)`));
  assert.match(await page.getByTestId('overlay-label').textContent(), new RegExp(`query: .* · ${NAME}`));
  // The distance map is drawn: the live canvas has a heatmap layer.
  assert.ok(await page.evaluate(() => window.__seespotLabels['live-canvas'].labels.some((l) => l.text === 'best')));
});

test('the embedding colours of the chosen pair show what the model (D = 100) sees', async () => {
  await page.getByTestId('clear-query').click();
  await page.getByTestId('show-embedding').check();
  await page.waitForFunction(() => document.body.dataset.embedding, null, { timeout: 60_000 });
  const e = await page.evaluate(() => window.seespot.embedding);
  const d = await api('/api/decision');
  assert.equal(e.pair, d.chosen, 'the page shows the chosen pair');
  assert.equal(e.policy, NAME);
  assert.equal(e.policy, d.pairs[e.pair].policy);
  assert.equal(e.rotation, d.pairs[e.pair].matched.rotation);
  assert.equal(await page.evaluate(() => document.body.dataset.embedding), `${NAME}:${e.version}`);
  const n = e.resolution;
  for (const key of ['live', 'demo_rgb']) {
    const px = Buffer.from(e[key], 'base64');
    assert.equal(px.length, n * n * 3, key);
    assert.ok(new Set(px).size > 16, `${key}: the colours vary over the scene`);
  }
  // The canvases show the colours, not the heightmaps.
  const shown = await page.evaluate(() => {
    const c = document.querySelector('[data-testid=demo-canvas]');
    const ctx = c.getContext('2d');
    const img = ctx.getImageData(0, 0, c.width, c.height).data;
    const colours = new Set();
    for (let i = 0; i < img.length; i += 4 * 97) colours.add((img[i] << 16) | (img[i + 1] << 8) | img[i + 2]);
    return colours.size;
  });
  assert.ok(shown > 16, `the demo canvas shows ${shown} colours`);
  assert.deepEqual(view.errors, []);
  assert.deepEqual(await page.evaluate(() => window.seespot.errors), []);
});

test('screenshot: embeddings.png', async () => {
  await page.screenshot({ path: join(shots, 'embeddings.png') });
  console.log(`screenshot: ${join(shots, 'embeddings.png')}`);
});

test('the page raised no script errors', () => {
  assert.deepEqual(view.errors, []);
});
