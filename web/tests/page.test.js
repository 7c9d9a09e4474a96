// Drives the seespot page in headless Chromium (playwright-core, Debian's
// /usr/bin/chromium): steps through the phases, checks the L / C table against
// the backend's explanation record, makes a click-to-query, checks bad input,
// two tabs, a tab closed mid-run, checks that the rerun web viewer shows the
// recording, and saves screenshots into $SEESPOT_SCREENSHOTS, else into a new
// temporary folder (printed). scripts/screenshots refreshes the committed
// ../screenshots with SEESPOT_SCREENSHOTS=screenshots.
//
// Server: $SEESPOT_BIN (default ../target/release/seespot) run as
// `$SEESPOT_BIN view --port 0 ...`; $SEESPOT_DECIDER and $SEESPOT_MODELS pass
// --decider and --models; $RERUN_BIN (pip rerun-sdk==0.36.3) verifies the .rrd.
// SEESPOT_WEB_FROM_DISK=1 serves web/'s files from disk (the binary embeds the
// ones it was built with; serve.js `pageFromDisk`).
import { gunzipSync } from 'node:zlib';
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import { mkdtempSync, mkdirSync, rmSync, statSync, existsSync, writeFileSync, renameSync, readdirSync, readFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';
import net from 'node:net';
import { chromium } from 'playwright-core';
import { decodePng, colourStats, showsBlocks } from './png.js';
import { root, BIN, CHROMIUM, startView, stopView, pageFromDisk } from './serve.js';

// Screenshots never go into the work tree unless asked for (scripts/screenshots).
const shots = process.env.SEESPOT_SCREENSHOTS
  ? resolve(process.env.SEESPOT_SCREENSHOTS)
  : mkdtempSync(join(tmpdir(), 'seespot-screenshots-'));
const RES = Number(process.env.SEESPOT_TEST_RESOLUTION || 224);
const FLAGS = ['--headless', '--no-sandbox', '--disable-gpu', '--enable-unsafe-swiftshader', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync'];

let server, urls = {}, context, page, profile, tmp, rrd, proxy;
const pageErrors = [];

async function startServer() {
  const args = ['view', '--port', '0', '--task', 'stack', '--seed', '1', '--resolution', String(RES), '--save', rrd];
  if (process.env.SEESPOT_DECIDER) args.push('--decider', process.env.SEESPOT_DECIDER);
  if (process.env.SEESPOT_MODELS) args.push('--models', process.env.SEESPOT_MODELS);
  const started = await startView(args, { viewer: true });
  server = started.server;
  // With SEESPOT_WEB_FROM_DISK=1 the page's files come from web/ (serve.js).
  proxy = await pageFromDisk(started.page);
  urls = { page: proxy.url, viewer: started.viewer };
}

before(async () => {
  assert.ok(existsSync(BIN), `no server binary at ${BIN}; build it with cargo build --release`);
  mkdirSync(shots, { recursive: true });
  console.log(`screenshots go to ${shots}`);
  tmp = mkdtempSync(join(tmpdir(), 'seespot-web-'));
  rrd = join(tmp, 'trial.rrd');
  profile = join(tmp, 'profile');
  await startServer();
  context = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM, headless: true, args: FLAGS, viewport: { width: 1500, height: 1150 },
  });
  page = await context.newPage();
  page.on('pageerror', (e) => pageErrors.push(String(e)));
  await page.goto(urls.page);
  await page.waitForFunction(() => window.seespot && window.seespot.state && window.seespot.frameVersion >= 0);
});

after(async () => {
  if (context) await context.close();
  if (proxy) await proxy.close();
  await stopView(server);
  if (tmp) rmSync(tmp, { recursive: true, force: true });
});

const api = async (path) => (await fetch(new URL(path, urls.page))).json();

/** Clicks a control and waits until the page has drawn the resulting state. */
async function stepAndWait(testid) {
  const v0 = await page.evaluate(() => window.seespot.state.version);
  await page.getByTestId(testid).click();
  await page.waitForFunction((v) => window.seespot.state.version > v && window.seespot.frameVersion === window.seespot.state.version, v0, { timeout: 120_000 });
}

async function tableRows(selector = '[data-testid=pairs] tbody tr') {
  return page.$$eval(selector, (trs) => trs.map((tr) => ({
    cells: [...tr.children].map((td) => td.textContent), chosen: tr.classList.contains('chosen'),
  })));
}

/** The table's rows that show a (policy, demo) pair: not the placeholder row
 * ("step to the embed phase", one cell spanning the table) app.js draws when
 * there are no pairs. */
const pairRows = () => tableRows('[data-testid=pairs] tbody tr[data-pair]');

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/** Screenshots `target` (a page or an element) until it shows the recording's
 * blocks, or fails after `ms`; returns the last screenshot (PNG). */
async function waitForBlocks(target, what, ms) {
  const deadline = Date.now() + ms;
  for (;;) {
    let last;
    try {
      const png = await target.screenshot({ timeout: 30_000 });
      const stats = colourStats(decodePng(png));
      if (showsBlocks(stats)) return png;
      last = JSON.stringify(stats);
    } catch (e) {
      last = `screenshot failed: ${e}`;
    }
    if (Date.now() > deadline) {
      assert.fail(`${what} does not show the recording (no blocks in its screenshot after ${ms / 1000} s): ${last}`);
    }
    await sleep(2_000);
  }
}

test('the page loads and shows the trial the backend runs', async () => {
  const s = await api('/api/state');
  assert.equal(await page.getByTestId('progress').textContent(), `${s.progress} / 4`);
  assert.equal(await page.getByTestId('task').inputValue(), s.task);
  assert.match(await page.getByTestId('conn').textContent(), /connected/);
  // Actions count from 1, as the rerun timeline and the viser view do.
  assert.equal(s.action_number, 1);
  assert.equal(await page.getByTestId('action-index').textContent(), '1');
  assert.equal(await page.getByTestId('end').textContent(), 'in progress');
  await page.screenshot({ path: join(shots, 'page-start.png') });
});

test('the "?" beside the phases opens the glossary of the page\'s words', async () => {
  const g = page.getByTestId('glossary');
  assert.ok(!(await g.locator('dl').isVisible()));
  await g.locator('summary').click();
  const text = await g.locator('dl').textContent();
  for (const word of ['SSR', 'SPOT-Q', 'ASE', 'L2CD', 'fold', 'demo n·s']) assert.ok(text.includes(word), word);
  await g.locator('summary').click();
  assert.ok(!(await g.locator('dl').isVisible()));
});

test('stepping phase by phase reveals L, then C, then the chosen pair, as in the explanation record', async () => {
  await stepAndWait('next-phase');
  let s = await api('/api/state');
  assert.equal(s.phase, 'embed');
  const d = await api('/api/decision');
  assert.ok(d && d.pairs.length > 0, 'the decider gave no explanation record');
  let rows = await tableRows();
  assert.equal(rows.length, d.pairs.length);
  rows.forEach((r, i) => {
    assert.equal(r.cells[1], d.pairs[i].policy);
    assert.equal(r.cells[3], '…');
  });
  await page.screenshot({ path: join(shots, 'phase-1-embed.png') });

  await stepAndWait('next-phase');
  assert.equal((await api('/api/state')).phase, 'match');
  rows = await tableRows();
  rows.forEach((r, i) => {
    assert.equal(r.cells[3], d.pairs[i].l.toFixed(3), `L of pair ${i}`);
    assert.equal(r.cells[4], '…');
  });
  assert.match(await page.getByTestId('overlay-label').textContent(), /match distance/);
  await page.screenshot({ path: join(shots, 'phase-2-match.png') });

  await stepAndWait('next-phase');
  rows = await tableRows();
  rows.forEach((r, i) => assert.equal(r.cells[4], d.pairs[i].c.toFixed(1), `C of pair ${i}`));
  assert.ok(rows.every((r) => !r.chosen));
  // CCD beside L2CD: the pair each would act on (the reference correspondence
  // breaks ties to the first pair, as numpy's argmin), marked whichever drives.
  const argmin = (k) => d.pairs.reduce((b, p, i) => (p[k] < d.pairs[b][k] ? i : b), 0);
  assert.equal(d.ccd_choice, argmin('c'));
  assert.equal(d.l2cd_choice, argmin('l'));
  rows.forEach((r, i) => {
    assert.equal(r.cells[6].includes('CCD'), i === d.ccd_choice, `CCD mark on pair ${i}`);
    assert.equal(r.cells[6].includes('L2CD'), i === d.l2cd_choice, `L2CD mark on pair ${i}`);
  });
  const said = await page.getByTestId('method-choices').textContent();
  const a = d.pairs[d.ccd_choice].matched, b = d.pairs[d.l2cd_choice].matched;
  assert.ok(said.includes(`CCD would take ${a.primitive} r${a.rotation} (${a.y}, ${a.x})`), said);
  assert.ok(said.includes(`L2CD would take ${b.primitive} r${b.rotation} (${b.y}, ${b.x})`), said);
  await page.screenshot({ path: join(shots, 'phase-3-verify.png') });

  await stepAndWait('next-phase');
  s = await api('/api/state');
  assert.equal(s.phase, 'act');
  rows = await tableRows();
  assert.deepEqual(rows.map((r) => r.chosen), d.pairs.map((_, i) => i === d.chosen));
  assert.equal(s.steps.length, 1);
  assert.deepEqual(s.steps[0].action, d.action);
  await page.screenshot({ path: join(shots, 'phase-4-act.png') });
});

test('click-to-query draws the ASE distance map the backend computes', async () => {
  await stepAndWait('next-phase'); // embed of the next action: a fresh decision
  const f = await page.evaluate(() => window.seespot.frame);
  const a = f.demo.action;
  await page.getByTestId('query-policy').selectOption('1');
  const box = await page.getByTestId('demo-canvas').boundingBox();
  const n = f.resolution;
  await page.mouse.click(box.x + (a.x + 0.5) * box.width / n, box.y + (a.y + 0.5) * box.height / n);
  await page.waitForFunction(() => window.seespot.lastQuery);
  const q = await page.evaluate(() => window.seespot.lastQuery);
  assert.deepEqual([q.y, q.x, q.policy, q.pair], [a.y, a.x, 1, f.pair]);
  // The same query from a second socket (a second client) gives the same map.
  const again = await page.evaluate(({ pair, y, x }) => new Promise((ok) => {
    const ws = new WebSocket(`ws://${location.host}/ws`);
    ws.onopen = () => ws.send(JSON.stringify({ type: 'query', pair, policy: 1, y, x }));
    ws.onmessage = (ev) => { const m = JSON.parse(ev.data); if (m.type === 'query') { ws.close(); ok(m); } };
  }), { pair: f.pair, y: a.y, x: a.x });
  assert.equal(again.map, q.map);
  assert.deepEqual(again.best, q.best);
  assert.match(await page.getByTestId('query-result').textContent(), new RegExp(`nearest live pixel \\(${q.best.y}, ${q.best.x}\\)`));
  assert.match(await page.getByTestId('overlay-label').textContent(), /query/);
  await page.screenshot({ path: join(shots, 'click-to-query.png') });
});

test('choosing another pair shows that pair', async () => {
  await stepAndWait('next-phase'); // match
  const rows = await page.$$('[data-testid=pairs] tbody tr');
  await rows[rows.length - 1].click();
  await page.waitForFunction((i) => window.seespot.frame && window.seespot.frame.pair === i, rows.length - 1);
  const f = await page.evaluate(() => window.seespot.frame);
  const d = await api('/api/decision');
  assert.equal(f.demo.demo, d.pairs[rows.length - 1].demo);
  assert.equal(f.demo.step, d.pairs[rows.length - 1].demo_step);
});

/** The frame the page drew, minus its version (which counts every change). */
const drawnFrame = () => page.evaluate(() => {
  const { version, ...f } = window.seespot.frame;
  return f;
});

test('going back in time shows exactly what was shown live', async () => {
  // Step through a whole action, keeping what each phase showed.
  const live = [];
  for (let k = 0; k < 5; k++) {
    await stepAndWait('next-phase');
    const s = await page.evaluate(() => window.seespot.state);
    live.push({
      index: s.history.len - 1, phase: s.phase, rows: await tableRows(),
      frame: await drawnFrame(), decision: await api('/api/decision'),
    });
  }
  await stepAndWait('next-action');
  const lenBefore = (await api('/api/state')).history.len;
  const latencies = [];
  for (const at of live) {
    const t0 = Date.now();
    const v0 = await page.evaluate(() => window.seespot.state.version);
    await page.$eval('[data-testid=timeline]', (el, i) => { el.value = String(i); el.dispatchEvent(new Event('input')); }, at.index);
    await page.waitForFunction(([i, v]) => window.seespot.state.version > v && window.seespot.state.history.viewing === i
      && window.seespot.frameVersion === window.seespot.state.version, [at.index, v0]);
    latencies.push(Date.now() - t0);
    const s = await page.evaluate(() => window.seespot.state);
    assert.equal(s.phase, at.phase, `phase at history ${at.index}`);
    assert.deepEqual(await tableRows(), at.rows, `pairs table at history ${at.index}`);
    assert.deepEqual(await drawnFrame(), at.frame, `heightmaps and distance maps at history ${at.index}`);
    assert.deepEqual(await api('/api/decision'), at.decision, `explanation record at history ${at.index}`);
    assert.match(await page.getByTestId('timeline-label').textContent(), /viewing/);
  }
  console.log(`time travel: a step back drawn in ${latencies.join(', ')} ms (page round trip, ${RES} px)`);
  await page.screenshot({ path: join(shots, 'time-travel.png') });
  // Looking back changes nothing: back to live, the trial is where it was.
  await page.getByTestId('go-live').click();
  await page.waitForFunction(() => window.seespot.state.history.viewing === null && window.seespot.frameVersion === window.seespot.state.version);
  const s = await api('/api/state');
  assert.equal(s.history.len, lenBefore);
  assert.equal(s.phase, 'act');
  // Out of range is refused with the range named.
  const reply = await page.evaluate(() => new Promise((ok) => {
    const ws = new WebSocket(`ws://${location.host}/ws`);
    ws.onopen = () => ws.send(JSON.stringify({ type: 'goto', index: 100000 }));
    ws.onmessage = (ev) => { const m = JSON.parse(ev.data); if (m.type === 'error') { ws.close(); ok(m.message); } };
  }));
  assert.match(reply, /out of range/);
});

test('embedding colours show what the pair\'s policy sees, live and demo', async () => {
  const s = await api('/api/state');
  if (!s.pairs.length) await stepAndWait('next-phase');
  await page.getByTestId('show-embedding').check();
  await page.waitForFunction(() => document.body.dataset.embedding, null, { timeout: 60_000 });
  const e = await page.evaluate(() => window.seespot.embedding);
  const d = await api('/api/decision');
  assert.equal(e.policy, d.pairs[e.pair].policy);
  assert.equal(e.rotation, d.pairs[e.pair].matched.rotation);
  const n = e.resolution;
  for (const key of ['live', 'demo_rgb']) {
    const px = Buffer.from(e[key], 'base64');
    assert.equal(px.length, n * n * 3, key);
    assert.ok(new Set(px).size > 16, `${key}: the colours vary over the scene`);
  }
  await page.screenshot({ path: join(shots, 'embedding-colours.png') });
  // Click-to-query still works on the coloured demo.
  const box = await page.getByTestId('demo-canvas').boundingBox();
  await page.mouse.click(box.x + box.width / 2, box.y + box.height / 2);
  await page.waitForFunction(() => window.seespot.query !== null, null, { timeout: 60_000 });
  await page.getByTestId('show-embedding').uncheck();
  await page.waitForFunction(() => !document.body.dataset.embedding);
});

test('the page saves the current layout as a scene file', async () => {
  const s = await api('/api/state');
  const r = await fetch(new URL(await page.getByTestId('save-layout').getAttribute('href'), urls.page));
  if (s.holding !== null) {
    assert.equal(r.status, 409, 'a layout with a block in the gripper is refused');
    return;
  }
  assert.equal(r.status, 200);
  const text = await r.text();
  assert.match(text, new RegExp(`task = "${s.task}"`));
  const positions = [...text.matchAll(/position = \[([^\]]+)\]/g)].map((m) => m[1].split(',').map(Number));
  assert.equal(positions.length, 4);
  positions.forEach((p, i) => p.forEach((v, k) => assert.ok(Math.abs(v - s.blocks[i].position[k]) < 1e-5, `block ${i} axis ${k}`)));
});

test('a malformed message gets an error and the server keeps serving', async () => {
  const replies = await page.evaluate(() => new Promise((ok) => {
    const ws = new WebSocket(`ws://${location.host}/ws`);
    const got = [];
    ws.onopen = () => { ws.send('{oops'); ws.send(JSON.stringify({ type: 'teleport' })); ws.send(JSON.stringify({ type: 'ping' })); };
    ws.onmessage = (ev) => { const m = JSON.parse(ev.data); if (m.type !== 'state' && m.type !== 'info') got.push(m.type); if (m.type === 'pong') { ws.close(); ok(got); } };
  }));
  assert.deepEqual(replies, ['error', 'error', 'pong']);
  assert.equal((await fetch(new URL('/api/state', urls.page))).status, 200);
});

test('only the page\'s own files are served', async () => {
  for (const target of ['/../Cargo.toml', '/%2e%2e/Cargo.toml', '/%2e%2e%2f%2e%2e%2fetc%2fpasswd', '/tests/page.test.js']) {
    const status = await new Promise((ok, fail) => {
      const u = new URL(urls.page);
      const s = net.connect(Number(u.port), u.hostname, () => s.write(`GET ${target} HTTP/1.1\r\nHost: ${u.host}\r\nConnection: close\r\n\r\n`));
      let buf = '';
      s.on('data', (d) => { buf += d; });
      s.on('end', () => ok(Number(buf.split(' ')[1])));
      s.on('error', fail);
    });
    assert.equal(status, 404, target);
  }
});

test('a tab closed mid-run stops nothing; the run finishes and every tab sees it', async () => {
  const other = await context.newPage();
  await other.goto(urls.page);
  await other.waitForFunction(() => window.seespot && window.seespot.state);
  await other.getByTestId('run').click();
  await other.close();
  await page.waitForFunction(() => window.seespot.state.end !== null, null, { timeout: 300_000 });
  await page.waitForFunction(() => window.seespot.frameVersion === window.seespot.state.version);
  const s = await api('/api/state');
  assert.ok(s.end);
  // How it ended, in words (not the record's key): a failure as the
  // review files it (issue 59).
  const said = await page.getByTestId('end').textContent();
  assert.equal(said, s.succeeded ? 'success ✓' : `failed: ${s.failure.label}`);
  assert.ok(!said.includes(s.end), said);
  // The table shows the last decision's pairs (the placeholder row is not one).
  const d = await api('/api/decision');
  assert.ok(d && d.pairs.length > 0, 'no explanation record at the end of the run');
  const rows = await pairRows();
  assert.equal(rows.length, d.pairs.length, 'pair rows in the table');
  assert.equal((await tableRows()).length, rows.length, 'rows that are not pairs');
  rows.forEach((r, i) => {
    assert.equal(r.cells[1], d.pairs[i].policy, `policy of pair ${i}`);
    assert.equal(r.cells[2], `${d.pairs[i].demo}·${d.pairs[i].demo_step}`, `demo of pair ${i}`);
    assert.equal(r.cells[3], d.pairs[i].l.toFixed(3), `L of pair ${i}`);
    assert.equal(r.cells[4], d.pairs[i].c.toFixed(1), `C of pair ${i}`);
  });
  assert.deepEqual(rows.map((r) => r.chosen), d.pairs.map((_, i) => i === d.chosen));
  assert.equal(await page.locator('[data-testid=history] li').count(), s.steps.length);
  await page.screenshot({ path: join(shots, 'trial-end.png'), fullPage: true });
});

test('reset starts a new trial with the chosen task and seed', async () => {
  await page.getByTestId('task').selectOption('row');
  await page.getByTestId('seed').fill('3');
  await page.getByTestId('reset').click();
  await page.waitForFunction(() => window.seespot.state.task === 'row' && window.seespot.state.seed === 3 && window.seespot.state.steps.length === 0, null, { timeout: 120_000 });
  await stepAndWait('next-action');
  const s = await api('/api/state');
  assert.equal(s.steps.length, 1);
  assert.equal(s.task, 'row');
});

test('the rerun web viewer loads and shows the recording', async () => {
  const viewer = await context.newPage();
  await viewer.goto(urls.viewer);
  // The viewer's wasm takes several seconds to compile: wait for its canvas, then let it draw.
  await viewer.waitForSelector('canvas', { timeout: 120_000 });
  await viewer.waitForTimeout(Number(process.env.SEESPOT_VIEWER_WAIT_MS || 20_000));
  // It has loaded the recording when its screenshot shows the blocks.
  // (Written whole, then renamed: png.test.js may be reading the committed one.)
  const shot = await waitForBlocks(viewer, 'the rerun web viewer', 120_000);
  writeFileSync(join(shots, '.rerun-viewer.png.tmp'), shot);
  renameSync(join(shots, '.rerun-viewer.png.tmp'), join(shots, 'rerun-viewer.png'));
  await viewer.close();
  // And the page's own embed.
  await page.getByTestId('toggle-viewer').click();
  assert.equal(await page.getByTestId('viewer').getAttribute('src'), urls.viewer);
  await page.frameLocator('[data-testid=viewer]').locator('canvas').first().waitFor({ timeout: 120_000 });
  await waitForBlocks(page.getByTestId('viewer'), 'the viewer embedded in the page', 120_000);
});

/** The committed evaluation's records, `method/task` -> records, read here
 * from the JSONL files themselves. */
function committedRecords() {
  const dir = join(root, 'results', 'trials');
  const out = new Map();
  for (const m of readdirSync(dir)) {
    for (const f of readdirSync(join(dir, m))) {
      if (!f.endsWith('.jsonl.gz')) continue;
      const recs = gunzipSync(readFileSync(join(dir, m, f))).toString('utf8').split('\n').filter((l) => l.trim()).map((l) => JSON.parse(l));
      out.set(`${m}/${f.slice(0, -'.jsonl.gz'.length)}`, recs);
    }
  }
  return out;
}

test('the review lists the evaluation with the JSONL\'s counts, sorted by failure kind, and replays a failure', async () => {
  const want = committedRecords();
  const review = await context.newPage();
  review.on('pageerror', (e) => pageErrors.push(String(e)));
  await review.goto(new URL('/review', urls.page).href);
  await review.waitForFunction(() => window.seespotReview.data !== null, null, { timeout: 120_000 });
  const rows = await review.$$eval('[data-testid=counts] tbody tr', (trs) => trs.map((tr) => ({
    key: `${tr.dataset.method}/${tr.dataset.task}`, cells: [...tr.children].map((td) => td.textContent),
  })));
  assert.equal(rows.length, want.size);
  const kinds = await review.evaluate(() => window.seespotReview.data.kinds.length);
  for (const r of rows) {
    const recs = want.get(r.key);
    assert.ok(recs, `the page lists ${r.key}, which has no records file`);
    const ok = recs.filter((x) => x.success).length;
    // Each run is labelled by the most privileged information it reads, as
    // its records say (issue 61).
    const reads = recs[0].provenance && recs[0].provenance.reads;
    assert.ok(['heightmaps', 'progress', 'simulator'].includes(r.cells[1]), `${r.key}: ${r.cells[1]}`);
    if (reads) assert.equal(r.cells[1], reads, r.key);
    assert.equal(Number(r.cells[3]), recs.length, r.key);
    assert.equal(r.cells[4].split(' ')[0], String(ok), r.key);
    // Every failure has exactly one kind.
    const byKind = r.cells.slice(5, 5 + kinds).map(Number);
    assert.equal(byKind.reduce((a, b) => a + b, 0), recs.length - ok, `${r.key}: ${r.cells}`);
  }
  const readsOf = (m) => rows.find((r) => r.key.startsWith(`${m}/`)).cells[1];
  assert.equal(readsOf('ssr-ccd'), 'heightmaps');
  assert.equal(readsOf('ssr-ccd-noloops'), 'progress');
  assert.equal(readsOf('ssr-ccd-replace'), 'simulator');
  // Listed failures come sorted by kind.
  const order = await review.evaluate(() => {
    const labels = window.seespotReview.data.kinds.map((k) => k.label);
    return [...document.querySelectorAll('[data-testid=trials] tbody tr')].map((tr) => labels.indexOf(tr.children[3].textContent));
  });
  assert.ok(order.length > 0);
  assert.ok(order.every((k, i) => k >= 0 && (i === 0 || k >= order[i - 1])), `kinds out of order: ${order}`);
  await review.screenshot({ path: join(shots, 'review.png'), fullPage: false });
  // Every shipped run replays; one that could not would say "no", the reason on hover.
  const refused = review.locator('[data-testid=counts] tbody td.refused');
  for (const td of await refused.all()) {
    assert.equal(await td.textContent(), 'no');
    assert.ok((await td.getAttribute('title')).length > 0);
  }

  // A count narrows the list to its trials.
  const cellsOfKind = review.locator('[data-testid=counts] tbody tr[data-method=ssr-ccd] td.count');
  await cellsOfKind.first().click();
  const n = Number(await cellsOfKind.first().textContent());
  assert.equal(await review.locator('[data-testid=trials] tbody tr').count(), n);

  // Replay the first SSR CCD failure of that kind: the debugger opens on it,
  // and its first action is the record's.
  const first = review.locator('[data-testid=trials] tbody tr').first();
  const [method, task, seed] = (await first.locator('td').allTextContents()).slice(0, 3);
  const rec = want.get(`${method}/${task}`).find((r) => r.seed === Number(seed));
  const replayButton = first.getByTestId('replay');
  if (process.env.SEESPOT_MODELS) {
    // Other models than the records were made with: refused, and said why.
    assert.ok(await replayButton.isDisabled());
    assert.match(await replayButton.getAttribute('title'), /checksum|differ|made with/);
    await review.close();
    return;
  }
  await replayButton.click();
  await review.waitForURL((u) => u.pathname === '/', { timeout: 120_000 });
  await review.waitForFunction(() => window.seespot && window.seespot.state && window.seespot.state.replay, null, { timeout: 120_000 });
  const s0 = await review.evaluate(() => window.seespot.state);
  assert.equal(s0.task, task);
  assert.equal(s0.seed, Number(seed));
  assert.match(s0.replay, new RegExp(`replay of ${method} on ${task} seed ${seed}`));
  assert.ok(await review.getByTestId('replay-banner').isVisible());
  const v0 = s0.version;
  await review.getByTestId('next-action').click();
  await review.waitForFunction((v) => window.seespot.state.version > v && window.seespot.state.steps.length === 1, v0, { timeout: 120_000 });
  const s1 = await review.evaluate(() => window.seespot.state);
  assert.deepEqual(s1.steps[0].action, rec.actions_log[0].action);
  assert.equal(s1.steps[0].progress_after, rec.actions_log[0].progress_after);
  await review.screenshot({ path: join(shots, 'replay.png'), fullPage: false });
  await review.close();

  // The shortest replayable SSR CCD trial as a rerun recording.
  const short = [...want.get(`ssr-ccd/unstack`)].sort((a, b) => a.actions - b.actions)[0];
  const q = new URLSearchParams({ method: 'ssr-ccd', task: 'unstack', seed: String(short.seed) });
  const res = await fetch(new URL(`/api/replay.rrd?${q}`, urls.page));
  assert.equal(res.status, 200, await res.clone().text());
  assert.match(res.headers.get('content-disposition'), /ssr-ccd-unstack-\d+\.rrd/);
  const bytes = Buffer.from(await res.arrayBuffer());
  assert.ok(bytes.length > 10_000, `${bytes.length} bytes`);
  if (process.env.RERUN_BIN) {
    const f = join(tmp, 'replay.rrd');
    writeFileSync(f, bytes);
    const r = spawnSync(process.env.RERUN_BIN, ['rrd', 'verify', f], { encoding: 'utf8' });
    assert.equal(r.status, 0, `rerun rrd verify failed:\n${r.stdout}\n${r.stderr}`);
  }
  // A trial that is not in the review is refused, naming what was asked for.
  const bad = await fetch(new URL('/api/replay.rrd?method=..%2Fmodels&task=stack&seed=1', urls.page));
  assert.equal(bad.status, 409);
  assert.match(await bad.text(), /no records of method/);
});

test('view --replay opens the trial marked as a replay, as the review\'s Replay button does', async () => {
  if (process.env.SEESPOT_MODELS) return; // the records were made with the shipped models
  const [rec] = committedRecords().get('ssr-ccd/unstack');
  const file = join('results', 'trials', 'ssr-ccd', 'unstack.jsonl.gz');
  const { server: child, page: served } = await startView(
    ['view', '--port', '0', '--no-viewer', '--replay', file, '--seed', String(rec.seed)]);
  const front = await pageFromDisk(served);
  const url = front.url;
  try {
    const p = await context.newPage();
    p.on('pageerror', (e) => pageErrors.push(String(e)));
    await p.goto(url);
    await p.waitForFunction(() => window.seespot && window.seespot.state && window.seespot.state.replay, null, { timeout: 120_000 });
    assert.match(await p.getByTestId('replay-banner').textContent(), new RegExp(`replay of ssr-ccd on unstack seed ${rec.seed}`));
    assert.ok(await p.getByTestId('replay-banner').isVisible());
    await p.close();
  } finally {
    await front.close();
    await stopView(child);
  }
});

test('the page raised no script errors', () => {
  assert.deepEqual(pageErrors, []);
});

test('Ctrl-C finishes the --save recording', async () => {
  await context.close();
  context = null;
  const exited = new Promise((r) => server.once('exit', r));
  server.kill('SIGINT');
  const code = await exited;
  assert.equal(code, 0);
  assert.ok(statSync(rrd).size > 10_000, 'the .rrd is (nearly) empty');
  // With the official viewer installed (pip install rerun-sdk==0.36.3), check the file.
  if (process.env.RERUN_BIN) {
    const r = spawnSync(process.env.RERUN_BIN, ['rrd', 'verify', rrd], { encoding: 'utf8' });
    assert.equal(r.status, 0, `rerun rrd verify failed:\n${r.stdout}\n${r.stderr}`);
    if ((process.env.SEESPOT_DECIDER || 'ssr') === 'ssr') {
      // What the chosen pair's policy sees (joint PCA colours) is in the recording.
      const p = spawnSync(process.env.RERUN_BIN, ['rrd', 'print', rrd], { encoding: 'utf8', maxBuffer: 256 << 20 });
      assert.equal(p.status, 0, `rerun rrd print failed:\n${p.stderr}`);
      assert.match(p.stdout, /corr\/[a-z-]+\/[01]\/pca_live/);
      assert.match(p.stdout, /corr\/[a-z-]+\/[01]\/pca_demo/);
    }
  }
});
