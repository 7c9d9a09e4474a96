// Demonstrate mode in headless Chromium: the live heightmap is the
// controller. A built-in task demonstrated by clicking the oracle's pixels and
// rotations saves the folder `seespot demo record` saves; a custom task
// demonstrated twice by clicks saves the shipped demonstrations
// (demos/custom/l-shape, made by scripts/demonstrate-custom through the same
// recorder), and See-SPOT-Run then runs on it with all four policies. The
// server saves into a copy of demos/ in a temporary folder; the screenshot
// demonstrate.png goes where page.test.js puts its screenshots.
//
// Server: $SEESPOT_BIN (default ../target/release/seespot).
// SEESPOT_WEB_FROM_DISK=1 serves web/'s files from disk (the binary embeds the
// ones it was built with; serve.js `pageFromDisk`).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import { mkdtempSync, mkdirSync, rmSync, existsSync, readFileSync, readdirSync, cpSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';
import { chromium } from 'playwright-core';
import { root, BIN, CHROMIUM, FLAGS, startView, stopView, pageFromDisk } from './serve.js';

const shots = process.env.SEESPOT_SCREENSHOTS
  ? resolve(process.env.SEESPOT_SCREENSHOTS)
  : mkdtempSync(join(tmpdir(), 'seespot-screenshots-'));

let server, pageUrl, context, page, tmp, demos, proxy;
const pageErrors = [];

async function startServer() {
  const args = ['view', '--port', '0', '--no-viewer', '--task', 'stack', '--seed', '1', '--demos', demos];
  let served;
  ({ server, page: served } = await startView(args));
  // With SEESPOT_WEB_FROM_DISK=1 the page's files come from web/ (serve.js).
  proxy = await pageFromDisk(served);
  pageUrl = proxy.url;
}

before(async () => {
  assert.ok(existsSync(BIN), `no server binary at ${BIN}; build it with cargo build --release`);
  mkdirSync(shots, { recursive: true });
  tmp = mkdtempSync(join(tmpdir(), 'seespot-demonstrate-'));
  demos = join(tmp, 'demos');
  cpSync(join(root, 'demos'), demos, { recursive: true });
  // The custom task is demonstrated anew here.
  rmSync(join(demos, 'custom', 'l-shape'), { recursive: true, force: true });
  await startServer();
  context = await chromium.launchPersistentContext(join(tmp, 'profile'), {
    executablePath: CHROMIUM, headless: true, args: FLAGS, viewport: { width: 1500, height: 1150 },
  });
  page = await context.newPage();
  page.on('pageerror', (e) => pageErrors.push(String(e)));
  await page.goto(pageUrl);
  await page.waitForFunction(() => window.seespot && window.seespot.state && window.seespot.frameVersion >= 0);
});

after(async () => {
  if (context) await context.close();
  if (proxy) await proxy.close();
  await stopView(server);
  if (tmp) rmSync(tmp, { recursive: true, force: true });
});

const state = () => page.evaluate(() => window.seespot.state);

/** Starts Demonstrate mode for `task` from `seed` by the page's controls. */
async function startDemonstrating(task, seed) {
  await page.getByTestId('demo-task').fill(task);
  await page.getByTestId('seed').fill(String(seed));
  await page.getByTestId('demo-start').click();
  await page.waitForFunction(([t, s]) => {
    const d = window.seespot.state.demonstrate;
    return d && d.task === t && d.seed === s && d.actions.length === 0;
  }, [task, seed]);
}

/** Turns the gripper to `rotation` with `]` and clicks the live heightmap at
 * pixel (y, x); waits until the server has executed the action. */
async function click(action, n) {
  const current = await page.evaluate(() => window.seespot.demoRotation);
  for (let k = 0; k < (action.rotation - current + 16) % 16; k++) await page.keyboard.press(']');
  assert.equal(await page.evaluate(() => window.seespot.demoRotation), action.rotation);
  const canvas = page.getByTestId('live-canvas');
  const box = await canvas.boundingBox();
  const res = (await state()).resolution;
  const position = { x: ((action.x + 0.5) / res) * box.width, y: ((action.y + 0.5) / res) * box.height };
  await canvas.hover({ position });
  await canvas.click({ position });
  await page.waitForFunction((k) => window.seespot.state.demonstrate.actions.length === k, n);
  const done = (await state()).demonstrate.actions[n - 1];
  assert.deepEqual(done, action, 'the click became the intended action');
}

/** Saves and returns the folder the server wrote. */
async function save() {
  const before = await page.evaluate(() => window.seespot.saved);
  await page.getByTestId('demo-save').click();
  await page.waitForFunction((b) => window.seespot.saved && window.seespot.saved !== b, before);
  const dir = await page.evaluate(() => window.seespot.saved);
  // Saving leaves Demonstrate mode for a fresh start of the trial it
  // interrupted (issue 59); the page still says where it saved.
  await page.waitForFunction(() => !window.seespot.state.demonstrate);
  const s = await state();
  assert.deepEqual([s.task, s.seed, s.steps.length, s.end], ['stack', 1, 0, null]);
  assert.ok(await page.getByTestId('demo-status').isVisible(), 'the saved message is shown');
  assert.equal(await page.getByTestId('demo-status').textContent(), `saved to ${dir}`);
  return dir;
}

function sameFiles(a, b) {
  const names = readdirSync(b).sort();
  assert.deepEqual(readdirSync(a).sort(), names);
  for (const f of names) assert.ok(readFileSync(join(a, f)).equals(readFileSync(join(b, f))), `${f} differs`);
}

test('a built-in task demonstrated by clicking the oracle\'s actions saves what `seespot demo record` saves', async () => {
  const ref = join(tmp, 'reference');
  const r = spawnSync(BIN, ['demo', 'record', '--task', 'stack', '--seed', '1', '--out', ref], { cwd: root, encoding: 'utf8' });
  assert.equal(r.status, 0, r.stderr);
  const actions = JSON.parse(readFileSync(join(ref, 'meta.json'), 'utf8')).steps.map((s) => s.action);
  await startDemonstrating('stack', 1);
  for (let i = 0; i < actions.length; i++) {
    await click(actions[i], i + 1);
    if (i === 2) {
      // Undo goes back one action; clicking it again continues.
      await page.getByTestId('demo-undo').click();
      await page.waitForFunction(() => window.seespot.state.demonstrate.actions.length === 2);
      await click(actions[i], i + 1);
    }
  }
  assert.equal((await state()).demonstrate.progress, 4);
  await page.screenshot({ path: join(shots, 'demonstrate.png') });
  const dir = await save();
  assert.equal(dir, join(demos, 'stack', '1'));
  sameFiles(dir, ref);
  // Saving over it again needs overwrite.
  await startDemonstrating('stack', 1);
  for (let i = 0; i < actions.length; i++) await click(actions[i], i + 1);
  const errors = (await page.evaluate(() => window.seespot.errors.length));
  await page.getByTestId('demo-save').click();
  await page.waitForFunction((n) => window.seespot.errors.length > n, errors);
  const last = await page.evaluate(() => window.seespot.errors.at(-1));
  assert.match(last, /holds a demonstration already; save with overwrite/, last);
  await page.getByTestId('demo-stop').click();
  await page.waitForFunction(() => !window.seespot.state.demonstrate);
  sameFiles(dir, ref);
});

test('bad demonstrations are refused with what is wrong', async () => {
  await startDemonstrating('stack', 3);
  const errors = () => page.evaluate(() => window.seespot.errors.join('\n'));
  // Nothing to save yet: Save waits for an action (issue 59), and the
  // server refuses a save sent anyway, with what is wrong; nothing written.
  assert.ok(await page.getByTestId('demo-save').isDisabled());
  await page.evaluate(() => window.seespot.ws.send(JSON.stringify({ type: 'demo_save', overwrite: false })));
  await page.waitForFunction(() => window.seespot.errors.some((e) => e.includes('no actions')));
  assert.ok(!existsSync(join(demos, 'stack', '3')));
  // An action outside the workspace (sent as the page would).
  await page.evaluate(() => window.seespot.ws.send(JSON.stringify({ type: 'demo_act', action: { primitive: 'grasp', rotation: 0, y: 500, x: 3 } })));
  await page.waitForFunction(() => window.seespot.errors.some((e) => e.includes('outside the')));
  // A grasp on the bare table (the corner) picks nothing: the page says so.
  await page.evaluate(() => window.seespot.ws.send(JSON.stringify({ type: 'demo_act', action: { primitive: 'grasp', rotation: 0, y: 1, x: 1 } })));
  await page.waitForFunction(() => window.seespot.state.demonstrate.actions.length === 1);
  assert.equal((await state()).holding, null);
  assert.match(await page.getByTestId('demo-status').textContent(), /^grasp missed: nothing was picked/);
  // A task name with a path in it.
  await page.getByTestId('demo-task').fill('custom:../escape');
  await page.getByTestId('demo-start').click();
  await page.waitForFunction(() => window.seespot.errors.some((e) => e.includes('holds no path')));
  assert.match(await errors(), /outside the 224 x 224 workspace/);
  assert.ok(!existsSync(join(tmp, 'escape')));
  await page.getByTestId('demo-stop').click();
});

test('a custom task demonstrated twice by clicks is what See-SPOT-Run then does, with all four policies', async () => {
  const shipped = join(root, 'demos', 'custom', 'l-shape');
  for (const n of ['0', '1']) {
    const meta = JSON.parse(readFileSync(join(shipped, n, 'meta.json'), 'utf8'));
    await startDemonstrating('custom:l-shape', meta.seed);
    for (let i = 0; i < meta.steps.length; i++) await click(meta.steps[i].action, i + 1);
    const dir = await save();
    assert.equal(dir, join(demos, 'custom', 'l-shape', n));
    // The clicks give the shipped demonstration, byte for byte.
    sameFiles(dir, join(shipped, n));
  }
  // Run See-SPOT-Run on it: the task box takes the new task.
  await page.getByTestId('task').selectOption('custom:l-shape');
  await page.getByTestId('seed').fill('1');
  await page.getByTestId('reset').click();
  await page.waitForFunction(() => window.seespot.state.task === 'custom:l-shape', null, { timeout: 120_000 });
  const v0 = (await state()).version;
  await page.getByTestId('next-phase').click();
  await page.waitForFunction((v) => window.seespot.state.version > v && window.seespot.state.pairs.length > 0, v0, { timeout: 120_000 });
  const s = await state();
  assert.deepEqual([...s.policies].sort(), ['row', 'stack', 'unstack', 'vertical-square']);
  const rows = await page.$$eval('[data-testid=pairs] tbody tr[data-pair]', (trs) => trs.map((tr) => tr.children[1].textContent));
  assert.deepEqual([...new Set(rows)].sort(), ['row', 'stack', 'unstack', 'vertical-square']);
  assert.equal(rows.length, 8, 'four policies x two demonstrations');
  assert.deepEqual(pageErrors, []);
});
