// The page served off loopback (`seespot view --bind 0.0.0.0 --allow-remote`):
// opened with the printed URL's token it works as on loopback (its fetch and
// WebSocket requests carry the HttpOnly cookie the server set), and without
// the token nothing is served.
//
// Server: $SEESPOT_BIN (default ../target/release/seespot), with the feature
// decider at 64 px and no rerun viewer, reached over 127.0.0.1.
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromium } from 'playwright-core';
import { CHROMIUM, FLAGS, startView, stopView } from './serve.js';


let server, pageUrl, stderr = '', context, tmp;

before(async () => {
  tmp = mkdtempSync(join(tmpdir(), 'seespot-remote-'));
  const args = ['view', '--bind', '0.0.0.0', '--allow-remote', '--port', '0', '--no-viewer',
    '--decider', 'features', '--task', 'stack', '--seed', '1', '--resolution', '64'];
  let stderrOf;
  ({ server, page: pageUrl, stderr: stderrOf } = await startView(args));
  // The warning is printed before the URL.
  stderr = stderrOf();
  context = await chromium.launchPersistentContext(join(tmp, 'profile'), {
    executablePath: CHROMIUM, headless: true, args: FLAGS,
  });
});

after(async () => {
  if (context) await context.close();
  await stopView(server);
  if (tmp) rmSync(tmp, { recursive: true, force: true });
});

/** The printed URL, reached over 127.0.0.1 (the server answers any name on its port). */
function local(url) {
  const u = new URL(url);
  u.hostname = '127.0.0.1';
  return u;
}

test('the warning is printed and the URL carries a token', () => {
  assert.match(stderr, /warning: serving the debugger on 0\.0\.0\.0/);
  assert.match(pageUrl, /\?token=[0-9a-f]{64}$/);
});

test('without the token the page, the API and the WebSocket are refused', async () => {
  const u = local(pageUrl);
  const base = `${u.protocol}//${u.host}`;
  for (const path of ['/', '/app.js', '/api/state', `/?token=${'0'.repeat(64)}`]) {
    const r = await fetch(base + path);
    assert.equal(r.status, 403, path);
  }
  const page = await context.newPage();
  const r = await page.goto(base + '/');
  assert.equal(r.status(), 403);
  await page.close();
});

test('with the token the page steps the trial over its WebSocket and API', async () => {
  const page = await context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  const r = await page.goto(local(pageUrl).toString());
  assert.equal(r.status(), 200);
  await page.waitForFunction(() => window.seespot && window.seespot.state && window.seespot.frameVersion >= 0,
    null, { timeout: 60_000 });
  // The cookie is HttpOnly: the page's scripts cannot read the token.
  assert.equal(await page.evaluate(() => document.cookie.includes('seespot-token')), false);
  const v0 = await page.evaluate(() => window.seespot.state.version);
  await page.getByTestId('next-phase').click();
  await page.waitForFunction((v) => window.seespot.state.version > v
    && window.seespot.frameVersion === window.seespot.state.version, v0, { timeout: 120_000 });
  assert.equal(await page.evaluate(() => window.seespot.state.phase), 'embed');
  // A same-origin fetch from the page (as app.js makes them) carries the cookie.
  const status = await page.evaluate(async () => (await fetch('/api/state')).status);
  assert.equal(status, 200);
  // Reloading without the token in the URL still works: the cookie is enough.
  const u = local(pageUrl);
  const again = await page.goto(`${u.protocol}//${u.host}/`);
  assert.equal(again.status(), 200);
  assert.deepEqual(errors, []);
  await page.close();
});
