// Issue 59's page items in headless Chromium, at 800 and 1280 px wide, on
// the README's first trial (`seespot view`: stack from seed 1, SSR CCD,
// reviewing results/):
// - the page names the trial's failure as `seespot review` files it
//   ("repeated identical action"), says it is the paper's method failing as
//   it does, and offers the same trial with seespot's extensions, which one
//   click replays (and solves);
// - Demonstrate mode after a finished replay shows none of its actions, end,
//   replay banner or task; Save waits for an action; leaving starts that
//   trial afresh;
// - the top bar, the trial box and the demonstrate box fit 800 px; a SPOT-Q
//   replay's demo side draws nothing; the difference view of two runs that
//   part at once does not say "the same 0 actions".
//
// Server: $SEESPOT_BIN (default ../target/release/seespot), no rerun viewer.
// SEESPOT_WEB_FROM_DISK=1 serves web/'s files from disk (serve.js).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync } from 'node:fs';
import { join } from 'node:path';
import { chromium } from 'playwright-core';
import { BIN, CHROMIUM, FLAGS, WEB_FROM_DISK, committedTrial, startView, stopView, pageFromDisk, pageFilesDiffering } from './serve.js';

const WIDTHS = [800, 1280];
let server, proxy, browser, context, page, pageUrl;
const errors = [];

before(async () => {
  assert.ok(existsSync(BIN), `no server binary at ${BIN}; build it with cargo build --release`);
  // The README's command, less the viewer and the fixed port.
  const started = await startView(['view', '--port', '0', '--no-viewer']);
  server = started.server;
  proxy = await pageFromDisk(started.page);
  pageUrl = proxy.url;
  if (!WEB_FROM_DISK) {
    const differing = await pageFilesDiffering(pageUrl);
    assert.deepEqual(differing, [], `${BIN} serves other page files than web/'s (${differing.join(', ')}): `
      + 'rebuild it, or set SEESPOT_WEB_FROM_DISK=1 to serve web/ from disk');
  }
  browser = await chromium.launch({ executablePath: CHROMIUM, headless: true, args: FLAGS });
  context = await browser.newContext({ viewport: { width: WIDTHS[0], height: 900 } });
  page = await context.newPage();
  page.on('pageerror', (e) => errors.push(String(e)));
  await page.goto(pageUrl);
  await page.waitForFunction(() => window.seespot && window.seespot.state && window.seespot.frameVersion >= 0);
});

after(async () => {
  if (browser) await browser.close();
  if (proxy) await proxy.close();
  await stopView(server);
});

const state = () => page.evaluate(() => window.seespot.state);

/** Waits until `pred(arg)` holds in the page (it reads
 *  `window.seespot.state`) and the page has drawn that state. */
async function until(pred, arg, timeout = 300_000) {
  await page.waitForFunction(pred, arg, { timeout });
  await page.waitForFunction(() => window.seespot.frameVersion === window.seespot.state.version, null, { timeout });
}

/** Runs the trial to its end by the page's button. */
async function runToEnd() {
  await page.getByTestId('run').click();
  await until(() => window.seespot.state.end !== null);
}

/** What overflows the window sideways: the page itself, or an element
 *  whose right edge is past it, or `ids` whose text is cut short. */
async function overflows(ids) {
  return page.evaluate((ids) => {
    const out = [];
    const W = document.documentElement.clientWidth;
    if (document.documentElement.scrollWidth > W) out.push(`the page is ${document.documentElement.scrollWidth} px wide`);
    const bar = document.querySelector('.topbar');
    if (bar.scrollWidth > bar.clientWidth) out.push(`the top bar holds ${bar.scrollWidth} px in ${bar.clientWidth}`);
    for (const el of bar.querySelectorAll('*')) {
      const r = el.getBoundingClientRect();
      if (r.width && r.right > W + 0.5) out.push(`top bar ${el.tagName}#${el.id} ends at ${r.right}`);
    }
    for (const id of ids) {
      const el = document.querySelector(`[data-testid=${id}]`);
      if (el.scrollWidth > el.clientWidth) out.push(`${id} "${el.textContent}" is cut: ${el.scrollWidth} px in ${el.clientWidth}`);
    }
    // A placeholder is cut where its text is wider than its box.
    const input = document.querySelector('[data-testid=demo-task]');
    const cs = getComputedStyle(input);
    const ctx = document.createElement('canvas').getContext('2d');
    ctx.font = `${cs.fontWeight} ${cs.fontSize} ${cs.fontFamily}`;
    const room = input.clientWidth - parseFloat(cs.paddingLeft) - parseFloat(cs.paddingRight);
    const need = ctx.measureText(input.placeholder).width;
    if (need > room) out.push(`the demonstrate box's placeholder needs ${need} px, has ${room}`);
    return out;
  }, ids);
}

test('the first trial fails as the review says, says why, and offers the extensions, which one click replays', async () => {
  const s0 = await state();
  assert.equal(`${s0.task} ${s0.seed}`, 'stack 1', 'the README\'s first trial');
  await runToEnd();
  const s = await state();
  const review = await (await fetch(new URL('/api/review', pageUrl))).json();
  const reviewed = review.trials.find((t) => t.method === 'ssr-ccd' && t.task === 'stack' && t.seed === 1);
  assert.equal(s.steps.length, reviewed.actions, 'the replayed trial is the recorded one');
  assert.equal(s.failure.kind, reviewed.failure, 'the page and the review agree');
  const label = review.kinds.find((k) => k.key === reviewed.failure).label;
  assert.equal(label, 'repeated identical action');
  for (const width of WIDTHS) {
    await page.setViewportSize({ width, height: 900 });
    assert.equal(await page.getByTestId('end').textContent(), `failed: ${label}`, `at ${width} px`);
    assert.ok(await page.getByTestId('failure-box').isVisible());
    assert.equal(await page.getByTestId('failure-kind').textContent(), `Trial failed: ${label}.`);
    assert.match(await page.getByTestId('failure-known').textContent(), /the paper's method fails most often/);
    assert.equal(await page.getByTestId('extensions-command').textContent(),
      'seespot view --replay results/trials/ssr-ccd-replace/stack.jsonl.gz --seed 1');
    const offer = page.getByTestId('try-extensions');
    assert.ok(await offer.isVisible());
    assert.match(await offer.textContent(), /seespot's extensions \(succeeded in 7 actions\)/);
    assert.deepEqual(await overflows(['end']), [], `at ${width} px`);
  }
  // One click: the same trial with the extensions, replayed from the review.
  const recorded = committedTrial(join('results', 'trials', 'ssr-ccd-replace', 'stack.jsonl.gz'), 1);
  await page.getByTestId('try-extensions').click();
  await until(() => { const s = window.seespot.state; return s.replay && s.replay.includes('ssr-ccd-replace') && s.steps.length === 0; }, null, 120_000);
  assert.ok(await page.getByTestId('replay-banner').isVisible());
  assert.ok(!(await page.getByTestId('failure-box').isVisible()), 'a new trial has no failure yet');
  await runToEnd();
  const t = await state();
  assert.equal(t.succeeded, true);
  assert.equal(t.steps.length, recorded.actions);
  assert.equal(await page.getByTestId('end').textContent(), 'success ✓');
  assert.ok(!(await page.getByTestId('failure-box').isVisible()));
  assert.deepEqual(errors, []);
});

test('Demonstrate mode shows nothing of the finished replay, saves only with an action, and returns to a fresh trial', async () => {
  const before = await state();
  assert.ok(before.end && before.replay, 'a finished replay (previous test)');
  for (const width of WIDTHS) {
    await page.setViewportSize({ width, height: 900 });
    await page.getByTestId('demo-task').fill('row');
    await page.getByTestId('seed').fill('3');
    await page.getByTestId('demo-start').click();
    await until(() => window.seespot.state.demonstrate && window.seespot.state.demonstrate.task === 'row');
    assert.equal(await page.locator('[data-testid=history] li').count(), 0, 'no actions of the replay');
    assert.equal(await page.getByTestId('end').textContent(), 'demonstrating');
    assert.equal(await page.getByTestId('action-index').textContent(), '0');
    assert.ok(!(await page.getByTestId('replay-banner').isVisible()), 'no replay banner');
    assert.ok(!(await page.getByTestId('failure-box').isVisible()));
    assert.equal(await page.getByTestId('task').inputValue(), 'row', 'the task box shows what is demonstrated');
    assert.ok(await page.getByTestId('timeline').isDisabled(), 'no history to travel');
    assert.ok(await page.getByTestId('demo-save').isDisabled(), 'nothing to save yet');
    assert.deepEqual(await overflows(['end']), [], `at ${width} px`);
    // One click on the live heightmap: an action, so something to save.
    const canvas = page.getByTestId('live-canvas');
    const box = await canvas.boundingBox();
    await canvas.click({ position: { x: box.width / 2, y: box.height / 2 } });
    await until(() => window.seespot.state.demonstrate && window.seespot.state.demonstrate.actions.length === 1);
    assert.ok(await page.getByTestId('demo-save').isEnabled());
    assert.equal(await page.locator('[data-testid=history] li').count(), 0);
    // Leave: the replayed trial again, from its start.
    await page.getByTestId('demo-stop').click();
    await until(() => !window.seespot.state.demonstrate);
    const s = await state();
    assert.equal(`${s.task} ${s.seed}`, `${before.task} ${before.seed}`);
    assert.deepEqual([s.steps.length, s.end, s.phase], [0, null, null], 'a fresh start, not the end it left');
    assert.equal(await page.getByTestId('end').textContent(), 'in progress');
    assert.equal(await page.getByTestId('task').inputValue(), before.task);
    assert.equal(await page.getByTestId('seed').inputValue(), String(before.seed));
    assert.ok(await page.getByTestId('replay-banner').isVisible(), 'the replayed trial, from its start');
    await runToEnd(); // back to a finished replay for the next width
  }
  assert.deepEqual(errors, []);
});

test('the top bar, the trial box and the demonstrate box fit at 800 and 1280 px', async () => {
  for (const width of WIDTHS) {
    await page.setViewportSize({ width, height: 900 });
    assert.deepEqual(await overflows(['end']), [], `at ${width} px`);
    // Every control of the top bar can be reached (none under another).
    for (const id of ['task', 'seed', 'reset', 'to-review', 'save-layout', 'conn']) {
      const hit = await page.getByTestId(id).evaluate((el) => {
        const r = el.getBoundingClientRect();
        const at = document.elementFromPoint(r.x + r.width / 2, r.y + r.height / 2);
        return at === el || el.contains(at);
      });
      assert.ok(hit, `${id} at ${width} px`);
    }
  }
});

test('long work on the server shows on the page as it goes, and goes when it is done', async () => {
  // The server's `busy` messages (protocol.rs), as a finetuned run's first
  // replay sends them each second (app/viz/tests/issue_59_page.rs checks
  // the server side), handed to the page's own handler.
  const busy = (m) => page.evaluate((m) => window.seespot.ws.onmessage({ data: JSON.stringify({ type: 'busy', ...m }) }), m);
  for (const width of WIDTHS) {
    await page.setViewportSize({ width, height: 900 });
    await busy({ what: 'the replay of transporter-finetuned on stack seed 1', why: 'it finetunes its models first', seconds: 42 });
    const banner = page.getByTestId('busy');
    assert.ok(await banner.isVisible());
    assert.equal(await banner.textContent(),
      '⏳ Preparing the replay of transporter-finetuned on stack seed 1: 42 s so far. it finetunes its models first');
    assert.deepEqual(await overflows([]), [], `at ${width} px`);
    // The page stays usable meanwhile: a control answers.
    assert.ok(await page.getByTestId('reset').isEnabled());
    await busy({ what: null, why: null, seconds: 43 });
    assert.ok(!(await banner.isVisible()));
  }
});

test('a SPOT-Q replay\'s demo side draws no demonstration marks', async () => {
  await page.setViewportSize({ width: 1280, height: 900 });
  await page.evaluate(() => window.seespot.ws.send(JSON.stringify({ type: 'replay', method: 'spot-q', task: 'stack', seed: 1 })));
  await until(() => { const s = window.seespot.state; return s.replay && s.replay.includes('spot-q') && s.steps.length === 0; }, null, 120_000);
  for (let i = 0; i < 3; i++) {
    const v = (await state()).version;
    await page.getByTestId('next-phase').click();
    await until((v0) => window.seespot.state.version > v0, v);
  }
  const s = await state();
  assert.equal(s.phase, 'verify');
  assert.equal(s.pairs.length, 1, 'the Q map');
  const labels = await page.evaluate(() => window.__seespotLabels['demo-canvas'].labels.map((l) => l.text));
  assert.deepEqual(labels.filter((t) => /demo|C =/.test(t)), [], labels.join(', '));
  assert.equal(await page.getByTestId('demo-title').textContent(), 'Demo (none)');
  assert.deepEqual(errors, []);
});

test('two runs that part at their first action are not said to share "0 actions"', async () => {
  // A stack seed where SSR CCD and SSR L2CD chose differently at once and
  // only one succeeded.
  const records = (run) => join('results', 'trials', run, 'stack.jsonl.gz');
  let seed = null;
  for (let s = 1; s < 100 && seed === null; s += 2) {
    const [a, b] = [committedTrial(records('ssr-ccd'), s), committedTrial(records('ssr-l2cd'), s)];
    if (!a || !b || a.success === b.success) continue;
    const [x, y] = [a.actions_log[0].action, b.actions_log[0].action];
    if (JSON.stringify(x) !== JSON.stringify(y)) seed = s;
  }
  assert.ok(seed !== null, 'a seed whose trials part at their first action');
  for (const width of WIDTHS) {
    await page.setViewportSize({ width, height: 900 });
    await page.goto(new URL(`/difference?a=ssr-ccd&b=ssr-l2cd&task=stack&seed=${seed}`, pageUrl).href);
    await page.waitForFunction(() => window.seespotDifference && window.seespotDifference.doc, null, { timeout: 240_000 });
    const summary = await page.getByTestId('summary').textContent();
    assert.equal(await page.evaluate(() => window.seespotDifference.doc.first_difference), 0);
    assert.ok(!/same 0 action/.test(summary), summary);
    assert.match(summary, /^They part at their first action: ssr-ccd took /);
  }
});
