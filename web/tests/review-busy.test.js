// A replay that must first prepare its models (issue 59): replaying a
// `transporter-finetuned` trial from the review finetunes its TransporterNet
// first (a minute or more on two cores, once), and the review page says so
// while it waits ("preparing ...: N s", the why in its tooltip) instead of
// showing nothing.
//
// Server: $SEESPOT_BIN (default ../target/release/seespot), reviewing
// results/. The server is stopped once the page has said it; the models are
// not kept: the server reads and writes them in an empty cache of its own
// (SEESPOT_CACHE).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { openView } from './serve.js';

let view;
// An empty finetune cache: the replay must prepare its models, on any machine.
const cache = mkdtempSync(join(tmpdir(), 'seespot-cache-'));

before(async () => {
  view = await openView(['view', '--port', '0', '--no-viewer', '--review', 'results'], { env: { SEESPOT_CACHE: cache } });
});

after(async () => {
  if (view) await view.close();
  rmSync(cache, { recursive: true, force: true });
});

test('the review says what a replay is preparing while it waits', async () => {
  const { page } = view;
  await page.goto(new URL('/review', view.pageUrl).href);
  await page.waitForFunction(() => window.seespotReview.data, null, { timeout: 120_000 });
  await page.getByTestId('method-filter').selectOption('transporter-finetuned');
  await page.getByTestId('show-successes').check();
  const replay = page.getByTestId('trial').first().getByTestId('replay');
  assert.equal(await replay.isEnabled(), true, await replay.getAttribute('title'));
  await replay.click();
  await page.waitForFunction(() => /^preparing .+: \d+ s$/.test(document.getElementById('conn').textContent),
    null, { timeout: 60_000 });
  const busy = await page.evaluate(() => window.seespotReview.busy);
  assert.ok(busy.what.startsWith('the replay of transporter-finetuned'), JSON.stringify(busy));
  assert.match(busy.why, /finetunes its models/);
  assert.ok((await page.locator('#conn').getAttribute('title')).length > 0);
  assert.deepEqual(view.errors, []);
});
