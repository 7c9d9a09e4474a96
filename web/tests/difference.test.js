// Two runs side by side, in headless Chromium: from the review page's list
// of seeds where SSR CCD and SSR L2CD disagree, the seed whose trials part
// latest opens the difference view; both sides open at the same action,
// where their actions differ, after the same earlier actions (checked
// against the committed records too). The slider moves both sides.
//
// Server: $SEESPOT_BIN (default ../target/release/seespot), reviewing
// results/. SEESPOT_SCREENSHOTS=DIR saves difference.png there.
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync, readFileSync, mkdtempSync, rmSync } from 'node:fs';
import { spawnSync } from 'node:child_process';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';
import { root, BIN, committedTrial, openView } from './serve.js';

let view;

function record(run, task, seed) {
  return committedTrial(join('results', 'trials', run, `${task}.jsonl.gz`), seed);
}

const key = (a) => `${a.primitive} ${a.rotation} ${a.y} ${a.x}`;

before(async () => {
  assert.ok(existsSync(BIN), `no server binary at ${BIN}; build it with cargo build --release`);
  view = await openView(['view', '--port', '0', '--no-viewer', '--review', 'results']);
});

after(async () => {
  if (view) await view.close();
});

test('a discordant CCD / L2CD seed opens both trials at the action where they part', async () => {
  const { page } = view;
  await page.goto(new URL('/review', view.pageUrl).href);
  await page.waitForFunction(() => window.seespotReview.discordant && window.seespotReview.discordant.list.length > 0,
    null, { timeout: 120_000 });
  assert.equal(await page.getByTestId('run-a').inputValue(), 'ssr-ccd');
  assert.equal(await page.getByTestId('run-b').inputValue(), 'ssr-l2cd');
  const list = await page.evaluate(() => window.seespotReview.discordant.list);
  // Sorted by where they part; every seed has one success and one failure.
  assert.ok(list.every((d, i) => i === 0 || d.action_index >= list[i - 1].action_index));
  for (const d of list.slice(0, 5)) {
    assert.notEqual(record('ssr-ccd', d.task, d.seed).success, record('ssr-l2cd', d.task, d.seed).success);
  }
  const rows = page.getByTestId('discordant-seed');
  assert.equal(await rows.count(), list.length);
  // The seed that parts latest: the most shared actions to check.
  const d = list[list.length - 1];
  assert.ok(d.action_index >= 1, `every discordant seed parts at its first action: ${JSON.stringify(d)}`);
  await rows.last().click();
  await page.waitForURL((u) => u.pathname === '/difference', { timeout: 30_000 });
  await page.waitForFunction(() => {
    const x = window.seespotDifference;
    return x && x.doc && x.views.a && x.views.b && document.body.dataset.action !== undefined;
  }, null, { timeout: 240_000 });
  const x = await page.evaluate(() => window.seespotDifference);
  assert.deepEqual(x.errors, []);
  assert.equal(x.doc.task, d.task);
  assert.equal(x.doc.seed, d.seed);
  assert.equal(x.doc.first_difference, d.action_index);
  // Both sides at the same action, the one where the two part.
  assert.equal(x.views.a.action, d.action_index);
  assert.equal(x.views.b.action, d.action_index);
  assert.equal(x.views.a.state.action_number, x.views.b.state.action_number);
  const [sa, sb] = [x.views.a.state.steps, x.views.b.state.steps];
  assert.notEqual(key(sa[d.action_index].action), key(sb[d.action_index].action));
  // Every earlier action the same, and the records' own.
  const [ra, rb] = [record('ssr-ccd', d.task, d.seed), record('ssr-l2cd', d.task, d.seed)];
  for (let i = 0; i < d.action_index; i++) {
    assert.equal(key(sa[i].action), key(sb[i].action), `action ${i + 1}`);
    assert.equal(key(sa[i].action), key(ra.actions_log[i].action), `action ${i + 1}`);
  }
  assert.equal(key(sa[d.action_index].action), key(ra.actions_log[d.action_index].action));
  assert.equal(key(sb[d.action_index].action), key(rb.actions_log[d.action_index].action));
  // Each side shows its decision: the chosen pair starred, its L and C.
  for (const side of ['a', 'b']) {
    const el = page.getByTestId(`side-${side}`);
    assert.equal(await el.locator('tbody tr.chosen').count(), 1);
    assert.match(await el.getByTestId('choice').textContent(), new RegExp(`^action ${d.action_index + 1}: grasp|^action ${d.action_index + 1}: place`));
    assert.ok(await el.getByTestId('choice').evaluate((e) => e.classList.contains('parts')));
    // Whether that side's match was right, as the simulator judges it.
    const st = x.views[side].state;
    const chosen = st.pairs[st.chosen];
    assert.ok(chosen.truth, `side ${side}: the chosen pair has no truth`);
    const right = chosen.truth.verdict === 'right';
    assert.ok((await el.getByTestId('choice').textContent()).includes(` · ${right ? 'right' : 'wrong'}`));
    assert.equal(await el.locator('tbody tr.chosen [data-testid=truth]').textContent(), right ? '✓' : '✗');
  }
  if (process.env.SEESPOT_SCREENSHOTS) {
    await page.screenshot({ path: join(resolve(process.env.SEESPOT_SCREENSHOTS), 'difference.png'), fullPage: false });
  }
  // One step back: both sides at the action before, where they agreed.
  await page.getByTestId('prev').click();
  await page.waitForFunction((k) => document.body.dataset.action === String(k), d.action_index - 1, { timeout: 60_000 });
  const y = await page.evaluate(() => window.seespotDifference.views);
  assert.equal(y.a.action, d.action_index - 1);
  assert.equal(y.b.action, d.action_index - 1);
  assert.equal(key(y.a.state.steps[d.action_index - 1].action), key(y.b.state.steps[d.action_index - 1].action));
  assert.ok(!(await page.getByTestId('side-a').getByTestId('choice').evaluate((e) => e.classList.contains('parts'))));
  assert.deepEqual(view.errors, []);
});

test('record --runs writes both trials of a seed into one recording, each under its own root', () => {
  const out = mkdtempSync(join(tmpdir(), 'seespot-two-runs-'));
  try {
    const r = spawnSync(BIN, ['record', '--task', 'stack', '--seed', '15', '--runs', 'ssr-ccd', 'ssr-l2cd', '--out', out, '--json'],
      { cwd: root, encoding: 'utf8' });
    assert.equal(r.status, 0, r.stderr);
    const file = JSON.parse(r.stdout).recordings[0].path;
    if (!process.env.RERUN_BIN) return;
    const verify = spawnSync(process.env.RERUN_BIN, ['rrd', 'verify', file], { encoding: 'utf8' });
    assert.equal(verify.status, 0, `rerun rrd verify failed:\n${verify.stdout}\n${verify.stderr}`);
    const print = spawnSync(process.env.RERUN_BIN, ['rrd', 'print', file], { encoding: 'utf8', maxBuffer: 64 << 20 });
    assert.equal(print.status, 0, print.stderr);
    for (const run of ['ssr-ccd', 'ssr-l2cd']) {
      for (const e of ['world/blocks', 'test/color', 'status']) assert.ok(print.stdout.includes(`runs/${run}/${e}`), `${run}/${e}`);
    }
  } finally { rmSync(out, { recursive: true, force: true }); }
});
