// Is the match right? on the page (issue 60), in headless Chromium: the
// pairs table's truth column says for each pair whether its F is right, as
// the simulator judges it on a copy of the world, and why (the cell's
// tooltip, and a line below the table for the shown pair); "shade right
// actions" draws the right actions' places on the live view. The trial:
// unstack from seed 1 with SSR CCD (`seespot view --task unstack`), whose
// first grasp, the tower's top, is right.
//
// Server: $SEESPOT_BIN (default ../target/release/seespot). Saves
// truth.png into $SEESPOT_SCREENSHOTS when it is set (scripts/screenshots).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { openView } from './serve.js';

const SHORT = { right: '✓', wrong_block: '✗', miss: '✗', no_progress: '✗', reversal: '✗', out: '✗' };

let view, page, stepAndWait;

before(async () => {
  view = await openView(['view', '--port', '0', '--no-viewer', '--task', 'unstack', '--seed', '1']);
  ({ page, stepAndWait } = view);
});

after(async () => {
  if (view) await view.close();
});

const cells = () => page.evaluate(() => [...document.querySelectorAll('#pairs-body tr[data-pair]')].map((tr) => {
  const td = tr.querySelector('[data-testid=truth]');
  return { text: td.textContent, title: td.title, cls: td.className, chosen: tr.classList.contains('chosen') };
}));

test('each pair\'s F says whether it is right, and why; the right actions can be shaded', async () => {
  // Embed: F is not shown yet, nor its truth.
  await stepAndWait('next-phase');
  let rows = await cells();
  assert.equal(rows.length, 6);
  assert.ok(rows.every((r) => r.text === '…'), JSON.stringify(rows));
  assert.equal(await page.getByTestId('truth-line').isVisible(), false);
  // Match: every F judged.
  await stepAndWait('next-phase');
  const s = await page.evaluate(() => window.seespot.state);
  rows = await cells();
  s.pairs.forEach((p, i) => {
    assert.ok(p.truth, `pair ${i} has no truth`);
    assert.equal(rows[i].text, SHORT[p.truth.verdict], `pair ${i}`);
    assert.ok(rows[i].title.includes(p.truth.why), rows[i].title);
    assert.equal(rows[i].cls, p.truth.verdict === 'right' ? 'right' : 'wrong');
  });
  // unstack's first grasp: the tower's top is the one right block.
  assert.ok(s.pairs.some((p) => p.truth.verdict === 'right'));
  assert.equal(s.right_targets.length, 1, JSON.stringify(s.right_targets));
  const line = await page.getByTestId('truth-line').textContent();
  assert.match(line, /^Truth: F of .* is (right|wrong)/);
  // Shaded: one label per right action on the live view.
  const labelled = () => page.evaluate(() => window.__seespotLabels['live-canvas'].labels.map((l) => l.text));
  assert.ok(!(await labelled()).some((t) => t.startsWith('right grasp')));
  await page.getByTestId('show-truth').check();
  await page.waitForFunction(() => window.__seespotLabels['live-canvas'].labels.some((l) => l.text.startsWith('right grasp')));
  assert.equal((await labelled()).filter((t) => t.startsWith('right grasp')).length, 1);
  if (process.env.SEESPOT_SCREENSHOTS) {
    await page.screenshot({ path: join(process.env.SEESPOT_SCREENSHOTS, 'truth.png') });
  }
  // Verify and act keep the truth; the next decision (a place) has its own.
  await stepAndWait('next-phase');
  await stepAndWait('next-phase');
  await stepAndWait('next-phase');
  await stepAndWait('next-phase');
  const place = await page.evaluate(() => window.seespot.state);
  assert.equal(place.primitive, 'place');
  assert.ok(place.pairs.every((p) => p.truth && p.truth.why));
  assert.deepEqual(view.errors, []);
});

test('the review gives each labelled run\'s match accuracy and each failed trial\'s first wrong step', async () => {
  const review = await openView(['view', '--port', '0', '--no-viewer', '--review', join('results', 'labelled')]);
  try {
    const p = review.page;
    await p.goto(new URL('/review', review.pageUrl).href);
    await p.waitForFunction(() => window.seespotReview.data, null, { timeout: 120_000 });
    const d = await p.evaluate(() => window.seespotReview.data);
    const row = d.counts.find((c) => c.method === 'ssr-ccd' && c.task === 'stack');
    assert.ok(row && row.truth, 'ssr-ccd on stack is labelled');
    const cell = p.locator('tr[data-method="ssr-ccd"][data-task="stack"] [data-testid=matches-right]');
    assert.equal(await cell.textContent(), `${Math.round((100 * row.truth.matches_right) / row.truth.matches)}%`);
    assert.match(await cell.getAttribute('title'), /matches right over 50 labelled trials/);
    // Every failed trial of a labelled run names its first wrong step.
    await p.getByTestId('method-filter').selectOption('ssr-ccd');
    const failed = d.trials.filter((t) => t.method === 'ssr-ccd' && !t.success);
    assert.ok(failed.length > 0 && failed.every((t) => t.truth && t.truth.first_wrong));
    const first = p.getByTestId('trial').first().getByTestId('first-wrong');
    assert.match(await first.textContent(), /^\d+: (no right match|wrong pair chosen|wrong action|every action right)$/);
    assert.match(await first.getAttribute('title'), /^action \d+ \((grasp|place)\): /);
    if (process.env.SEESPOT_SCREENSHOTS) {
      await p.screenshot({ path: join(process.env.SEESPOT_SCREENSHOTS, 'review-truth.png') });
    }
    assert.deepEqual(review.errors, []);
  } finally {
    await review.close();
  }
});
