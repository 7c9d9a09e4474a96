// Screenshots one page in headless Chromium (playwright-core, Debian's
// /usr/bin/chromium) once it has drawn: `node web/shoot.mjs URL OUT.png [WAIT_MS]`.
// Used by the Python tests for the viser 3-D view (a WebGL page).
import { chromium } from 'playwright-core';

const [url, out, wait = '4000'] = process.argv.slice(2);
if (!url || !out) {
  console.error('usage: node web/shoot.mjs URL OUT.png [WAIT_MS]');
  process.exit(2);
}
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  headless: true,
  args: ['--no-sandbox', '--enable-unsafe-swiftshader', '--use-angle=swiftshader', '--no-first-run',
    '--disable-background-networking', '--disable-component-update', '--disable-sync'],
});
try {
  const page = await browser.newPage({ viewport: { width: 1400, height: 900 } });
  await page.goto(url, { waitUntil: 'load' });
  await page.waitForSelector('canvas', { timeout: 60_000 });
  await page.waitForTimeout(Number(wait));
  await page.screenshot({ path: out });
} finally {
  await browser.close();
}
