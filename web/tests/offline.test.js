// The debugger asks no host but this machine (issue 59, item 7), in
// headless Chromium: the page, the review, and rerun's web viewer (shown in
// the page and opened on its own, with a trial streaming to it) make no
// request to any other host. rerun's viewer would report to tel.rerun.io,
// fetch a manifest from app.rerun.io and a font from fonts.googleapis.com;
// seespot serves it with those links left out and a Content-Security-Policy
// that keeps every other request in the browser (src/recording/web_viewer.rs).
// Chromium resolves no name here but 127.0.0.1, so nothing could leave the
// machine even if the test failed; every request is seen all the same.
//
// Server: $SEESPOT_BIN built with the `rerun` feature (the viewer is part
// of it; without it the test says so and checks the page alone).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync } from 'node:fs';
import { chromium } from 'playwright-core';
import { BIN, CHROMIUM, FLAGS, startView, stopView } from './serve.js';

let server, urls, browser, context;
const outside = [];
const local = [];
const refused = [];

const isLocal = (u) => {
  try {
    const { protocol, hostname } = new URL(u);
    if (['data:', 'blob:', 'about:', 'chrome-error:'].includes(protocol)) return true;
    return hostname === '127.0.0.1' || hostname === 'localhost' || hostname === '[::1]';
  } catch { return false; }
};

before(async () => {
  assert.ok(existsSync(BIN), `no server binary at ${BIN}; build it with cargo build --release --features rerun`);
  const started = await startView(['view', '--port', '0'], { viewer: true }).catch(async () => null);
  if (started) ({ server } = started);
  urls = started;
  browser = await chromium.launch({
    executablePath: CHROMIUM, headless: true,
    args: [...FLAGS, '--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1'],
  });
  context = await browser.newContext({ viewport: { width: 1280, height: 900 } });
  const seen = (r) => (isLocal(r.url()) ? local : outside).push(r.url());
  context.on('request', seen);
  context.on('console', (m) => { if (/Content.Security.Policy/i.test(m.text())) refused.push(m.text()); });
});

after(async () => {
  if (browser) await browser.close();
  await stopView(server);
});

test('the page, the review and rerun\'s viewer ask no host but this machine', async () => {
  assert.ok(urls, 'seespot view with the rerun viewer did not start: build with --features rerun');
  const page = await context.newPage();
  await page.goto(urls.page);
  await page.waitForFunction(() => window.seespot && window.seespot.state && window.seespot.frameVersion >= 0);
  // A trial streams to the viewer: an action decided and executed.
  const v0 = await page.evaluate(() => window.seespot.state.version);
  await page.getByTestId('next-action').click();
  await page.waitForFunction((v) => window.seespot.state.version > v, v0, { timeout: 120_000 });
  // The viewer shown in the page.
  await page.getByTestId('toggle-viewer').click();
  const frame = page.frameLocator('[data-testid=viewer]');
  await frame.locator('#the_canvas_id').waitFor({ state: 'attached', timeout: 60_000 });
  // The viewer on its own page, as the printed URL opens it.
  const alone = await context.newPage();
  const wasm = alone.waitForResponse((r) => r.url().endsWith('/re_viewer_bg.wasm'), { timeout: 120_000 });
  await alone.goto(urls.viewer);
  assert.equal((await wasm).status(), 200);
  await alone.waitForFunction(() => {
    const c = document.getElementById('the_canvas_id');
    return c && !c.classList.contains('hidden');
  }, null, { timeout: 120_000 });
  // rerun's analytics flush every 2 s: give them several chances.
  await alone.waitForTimeout(8000);
  await page.goto(new URL('/review', urls.page).href);
  await page.waitForFunction(() => window.seespotReview && window.seespotReview.data, null, { timeout: 120_000 });
  // The viewer did its work: it fetched its files and the gRPC stream.
  const grpcPort = new URL(decodeURIComponent(new URL(urls.viewer).searchParams.get('url')).replace('rerun+', '')).port;
  assert.ok(local.some((u) => new URL(u).port === grpcPort), `no request to the gRPC stream on port ${grpcPort}:\n${local.join('\n')}`);
  assert.deepEqual(outside, [], `requests to other hosts:\n${outside.join('\n')}\n(the browser refused: ${refused.length})`);
});
