// A replay that must first prepare its models (issue 59): replaying a
// `transporter-finetuned` trial from the review finetunes its TransporterNet
// first (a minute or more on two cores, once), and the review page says so
// while it waits ("preparing ...: N s", the why in its tooltip) instead of
// showing nothing.
//
// When that page leaves, the finetuning stops and nothing half made is kept.
//
// Server: $SEESPOT_BIN (default ../target/release/seespot), reviewing
// results/, with a copy of the base models (without models/finetuned/, which
// ships these finetunes ready made) and an empty cache of its own
// (SEESPOT_CACHE), so the replay must prepare its models on any machine.
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { cpSync, mkdirSync, mkdtempSync, readdirSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { openView, root } from './serve.js';

let view;
// An empty finetune cache: the replay must prepare its models, on any machine.
const cache = mkdtempSync(join(tmpdir(), 'seespot-cache-'));
const models = join(cache, 'models');

before(async () => {
  mkdirSync(join(models, 'transporter'), { recursive: true });
  for (const f of readdirSync(join(root, 'models')).filter((f) => f.endsWith('.safetensors'))) {
    cpSync(join(root, 'models', f), join(models, f));
  }
  cpSync(join(root, 'models', 'transporter'), join(models, 'transporter'), { recursive: true });
  view = await openView(['view', '--port', '0', '--no-viewer', '--review', 'results', '--models', models],
    { env: { SEESPOT_CACHE: cache } });
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

test('leaving the page stops the finetuning its replay started', async () => {
  const { page } = view;
  // Another tab hears the server's busy messages too.
  const other = await page.context().newPage();
  await other.goto(view.pageUrl);
  await other.waitForFunction(() => window.seespot && window.seespot.state);
  await other.waitForFunction(() => window.seespot.busy
    && /transporter-finetuned/.test(window.seespot.busy.what), null, { timeout: 10_000 });
  // The review page that asked leaves; the finetune (minutes) stops within
  // a training step and the server says it is no longer busy.
  await page.goto('about:blank');
  await other.waitForFunction(() => window.seespot.busy === null, null, { timeout: 30_000 });
  const kept = readdirSync(cache).includes('finetuned') ? readdirSync(join(cache, 'finetuned')) : [];
  assert.deepEqual(kept, [], 'a stopped finetune keeps nothing');
  await other.close();
});
