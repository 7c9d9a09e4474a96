// An extension of See-SPOT-Run on the page, in headless Chromium: the
// committed test trial of `ssr-ccd-noloops@raw-patches` on stack from seed 9
// (seespot's loop and put-back breaking on the raw-patch control), replayed
// with `view --replay`. Its first grasp fails and leaves the scene as it
// was; SSR CCD would take the same grasp again, the extension masks it and
// its 2 cm, and the page says so beside the pairs table.
//
// Server: $SEESPOT_BIN (default ../target/release/seespot).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { openReplay } from './serve.js';

const RECORDS = join('results', 'trials', 'ssr-ccd-noloops@raw-patches', 'stack.jsonl.gz');
const SEED = 9;

let view, page, stepAndWait, record;

before(async () => {
  ({ view, record } = await openReplay(RECORDS, SEED));
  ({ page, stepAndWait } = view);
});

after(async () => {
  if (view) await view.close();
});

test('the extension\'s departure from SSR CCD is explained beside the pairs', async () => {
  const first = record.actions_log[0];
  assert.equal(first.primitive_success, false, 'the trial must start with a failed grasp');
  // Action 1: four phases; no departure yet.
  for (let i = 0; i < 4; i++) await stepAndWait('next-phase');
  assert.equal(await page.getByTestId('departures').isVisible(), false);
  // Action 2, embed: the same scene as action 1's, so the failed grasp is skipped.
  await stepAndWait('next-phase');
  const note = page.getByTestId('departures');
  await note.waitFor({ state: 'visible' });
  const text = await note.textContent();
  const a = first.action;
  assert.match(text, /^Extension: /);
  assert.ok(text.includes(`grasp r${a.rotation} (${a.y}, ${a.x}) and the 2 cm around it skipped: it left the scene unchanged`), text);
  // The decision acts elsewhere, as the record does.
  for (let i = 0; i < 3; i++) await stepAndWait('next-phase');
  const s = await page.evaluate(() => window.seespot.state);
  const b = record.actions_log[1].action;
  assert.deepEqual([s.action.rotation, s.action.y, s.action.x], [b.rotation, b.y, b.x]);
  assert.notDeepEqual([b.rotation, b.y, b.x], [a.rotation, a.y, a.x]);
  assert.deepEqual(view.errors, []);
});

test('the review lists the extension\'s departures of a trial, each with its action and why', async () => {
  const want = record.actions_log.flatMap((a, i) => (a.departures || []).map((d) =>
    `action ${i + 1}: ${d.action.primitive} r${d.action.rotation} (${d.action.y}, ${d.action.x}) and the 2 cm around it skipped: ${d.why}`));
  assert.ok(want.length > 0, 'the record carries its departures');
  await page.goto(new URL('/review', view.pageUrl).href);
  await page.waitForFunction(() => window.seespotReview.data, null, { timeout: 120_000 });
  await page.getByTestId('method-filter').selectOption('ssr-ccd-noloops@raw-patches');
  await page.getByTestId('show-successes').check();
  const row = page.getByTestId('trial').filter({ has: page.locator('td', { hasText: /^stack$/ }) })
    .filter({ has: page.locator('td', { hasText: new RegExp(`^${SEED}$`) }) });
  assert.equal(await row.count(), 1);
  const cell = row.getByTestId('departures');
  assert.equal(await cell.textContent(), String(want.length));
  assert.deepEqual((await cell.getAttribute('title')).split('\n'), want);
  assert.match(want[0], /^action 2: grasp .* it left the scene unchanged$/);
});
