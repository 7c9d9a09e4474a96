// Regrasp and replacing on the page, in headless Chromium: the committed
// test trial of `ssr-ccd-replace@raw-patches` on row from seed 21, replayed
// with `view --replay`. Its first grasp, on a block, fails; regrasp masks
// only that grasp's axis, and the next grasp takes the same spot at
// another angle. Its second place leaves progress where it was; at the
// next place decision replacing masks it, and the block goes elsewhere.
// The page says each beside the pairs table, in the record's words.
//
// Server: $SEESPOT_BIN (default ../target/release/seespot).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { join } from 'node:path';
import { openReplay } from './serve.js';

const RECORDS = join('results', 'trials', 'ssr-ccd-replace@raw-patches', 'row.jsonl.gz');
const SEED = 21;
const PHASES = 4;

let view, page, stepAndWait, record;

before(async () => {
  ({ view, record } = await openReplay(RECORDS, SEED));
  ({ page, stepAndWait } = view);
});

after(async () => {
  if (view) await view.close();
});

const said = (d) => `${d.action.primitive} r${d.action.rotation} (${d.action.y}, ${d.action.x}) and the 2 cm around it skipped: ${d.why}`;

// Steps to action `i`'s embed phase (0-based) and returns the page's note.
let at = 0;
async function noteOf(i) {
  for (; at < PHASES * i + 1; at++) await stepAndWait('next-phase');
  const note = page.getByTestId('departures');
  await note.waitFor({ state: 'visible' });
  return note.textContent();
}

test('regrasp: a failed grasp on a block is skipped on its axis only, and the same spot is taken at another angle', async () => {
  const [first, second] = record.actions_log;
  assert.equal(first.primitive_success, false, 'the trial must start with a failed grasp');
  const d = second.departures.find((x) => x.why.includes('grasp axis'));
  assert.ok(d, 'the second action carries a regrasp departure');
  const text = await noteOf(1);
  assert.ok(text.includes(`Extension: ${said(d)}.`), text);
  assert.match(text, /another angle there may catch the block/);
  // The decision acts at the same pixel, at a rotation off the failed axis.
  for (let i = 0; i < PHASES - 1; i++, at++) await stepAndWait('next-phase');
  const s = await page.evaluate(() => window.seespot.state);
  const a = first.action;
  assert.deepEqual([s.action.y, s.action.x], [a.y, a.x]);
  assert.notEqual(s.action.rotation % 8, a.rotation % 8);
  assert.deepEqual(view.errors, []);
});

test('replacing: a place that left progress where it was is skipped, and the block goes elsewhere', async () => {
  const i = record.actions_log.findIndex((s) => (s.departures || []).some((d) => d.action.primitive === 'place'));
  assert.ok(i > 1, 'a later place decision carries a replaced place');
  const d = record.actions_log[i].departures.find((x) => x.action.primitive === 'place');
  const text = await noteOf(i);
  assert.ok(text.includes(`Extension: ${said(d)}.`), text);
  assert.match(text, /it left progress where it was/);
  for (let k = 0; k < PHASES - 1; k++, at++) await stepAndWait('next-phase');
  const s = await page.evaluate(() => window.seespot.state);
  const b = record.actions_log[i].action;
  assert.deepEqual([s.action.primitive, s.action.rotation, s.action.y, s.action.x], [b.primitive, b.rotation, b.y, b.x]);
  assert.ok(Math.max(Math.abs(b.y - d.action.y), Math.abs(b.x - d.action.x)) > 10, 'the place is outside the masked 2 cm');
  assert.deepEqual(view.errors, []);
});
