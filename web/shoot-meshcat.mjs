// Screenshots a standalone meshcat animation (seespot.viz.meshcat's HTML file)
// in headless Chromium with the network cut off, at one moment of the
// animation: `node web/shoot-meshcat.mjs TRIAL.html OUT.png [SECONDS]`.
// Fails when the page asks for anything but itself (it must open offline) or
// when it logs an error.
import { chromium } from 'playwright-core';
import { pathToFileURL } from 'node:url';
import { resolve } from 'node:path';

const [file, out, at = '3.6'] = process.argv.slice(2);
if (!file || !out) {
  console.error('usage: node web/shoot-meshcat.mjs TRIAL.html OUT.png [SECONDS]');
  process.exit(2);
}
const url = pathToFileURL(resolve(file)).href;
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  headless: true,
  args: ['--no-sandbox', '--enable-unsafe-swiftshader', '--use-angle=swiftshader', '--no-first-run',
    '--disable-background-networking', '--disable-component-update', '--disable-sync'],
});
const problems = [];
try {
  const page = await browser.newPage({ viewport: { width: 1400, height: 900 } });
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('console', (m) => { if (m.type() === 'error') problems.push(`console error: ${m.text()}`); });
  await page.route('**/*', (route) => {
    const u = route.request().url();
    if (u === url || u.startsWith('data:') || u.startsWith('blob:')) return route.continue();
    problems.push(`network request: ${u}`);
    return route.abort();
  });
  await page.goto(url, { waitUntil: 'load' });
  await page.waitForSelector('canvas', { timeout: 60_000 });
  // Stop the animation at the moment asked for, then let it draw.
  await page.evaluate((t) => {
    const a = window.viewer.animator;
    a.pause();
    a.seek(t);
  }, Number(at));
  await page.waitForTimeout(1500);
  await page.screenshot({ path: out });
} finally {
  await browser.close();
}
if (problems.length) {
  console.error(problems.join('\n'));
  process.exit(1);
}
