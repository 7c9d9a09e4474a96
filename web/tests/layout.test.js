// The page's layout at 1280 x 900 and 1440 x 1100 in headless Chromium: at
// every phase the heightmaps' labels do not cover each other and stay on
// their canvas, every cell of the pairs table is one line and the table fits
// its panel, and the status row's cells and the two heightmaps keep their
// places between phases and actions. Also: PCA colours are turned off, with a
// note, while viewing history, and a refused request is told in plain words.
//
// Server: $SEESPOT_BIN (default ../target/release/seespot), no rerun viewer.
// The binary embeds web/ when it is built: against an older binary, set
// SEESPOT_WEB_FROM_DISK=1 to serve web/ from disk (serve.js `pageFromDisk`).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync } from 'node:fs';
import { chromium } from 'playwright-core';
import { BIN, CHROMIUM, FLAGS, WEB_FROM_DISK, startView, stopView, pageFromDisk, pageFilesDiffering } from './serve.js';

let server, proxy, browser, pageUrl;

before(async () => {
  assert.ok(existsSync(BIN), `no server binary at ${BIN}; build it with cargo build --release`);
  const started = await startView(['view', '--port', '0', '--no-viewer', '--task', 'stack', '--seed', '1']);
  server = started.server;
  proxy = await pageFromDisk(started.page);
  pageUrl = proxy.url;
  if (!WEB_FROM_DISK) {
    const differing = await pageFilesDiffering(pageUrl);
    assert.deepEqual(differing, [], `${BIN} serves other page files than web/'s (${differing.join(', ')}): `
      + 'rebuild it (cargo build --release), or set SEESPOT_WEB_FROM_DISK=1 to serve web/ from disk');
  }
  browser = await chromium.launch({ executablePath: CHROMIUM, headless: true, args: FLAGS });
});

after(async () => {
  if (browser) await browser.close();
  if (proxy) await proxy.close();
  await stopView(server);
});

/** A page on the server at `viewport`, with a new trial of stack from seed 1. */
async function openPage(viewport) {
  const context = await browser.newContext({ viewport });
  const page = await context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  await page.goto(pageUrl);
  await page.waitForFunction(() => window.seespot && window.seespot.state && window.seespot.frameVersion >= 0);
  await page.getByTestId('task').selectOption('stack');
  await page.getByTestId('seed').fill('1');
  const v0 = await page.evaluate(() => window.seespot.state.version);
  await page.getByTestId('reset').click();
  await page.waitForFunction((v) => {
    const s = window.seespot.state;
    return s.version > v && s.steps.length === 0 && s.phase === null && window.seespot.frameVersion === s.version;
  }, v0, { timeout: 120_000 });
  return { context, page, errors };
}

/** Clicks a control and waits until the page has drawn the resulting state. */
async function stepAndWait(page, testid) {
  const v0 = await page.evaluate(() => window.seespot.state.version);
  await page.getByTestId(testid).click();
  await page.waitForFunction((v) => window.seespot.state.version > v
    && window.seespot.frameVersion === window.seespot.state.version, v0, { timeout: 120_000 });
}

/** The boxes that must not move: the status row's cells and the heightmaps. */
const STEADY = ['action-index', 'progress', 'primitive', 'end', 'demo-canvas', 'live-canvas'];
async function boxes(page) {
  return page.evaluate((ids) => {
    const out = {};
    const put = (name, el) => {
      const r = el.getBoundingClientRect();
      out[name] = [r.x, r.y, r.width, r.height].map((v) => Math.round(v * 10) / 10);
    };
    for (const id of ids) put(id, document.querySelector(`[data-testid=${id}]`));
    // The status row's cells: each label and value.
    document.querySelectorAll('.facts > div').forEach((d, i) => put(`facts cell ${i}`, d));
    return out;
  }, STEADY);
}

function sameBoxes(got, want, where) {
  for (const k of Object.keys(want)) {
    want[k].forEach((v, i) => assert.ok(Math.abs(got[k][i] - v) <= 0.5,
      `${where}: ${k} moved or changed size: [x, y, w, h] ${JSON.stringify(want[k])} -> ${JSON.stringify(got[k])}`));
  }
}

/** The labels drawn on both heightmaps (app.js puts them on
 *  window.__seespotLabels), each checked against the canvas's pixels: its
 *  left padding is the label's dark background. */
async function drawnLabels(page) {
  return page.evaluate(() => {
    const out = {};
    for (const [id, d] of Object.entries(window.__seespotLabels || {})) {
      const canvas = document.getElementById(id);
      const ctx = canvas.getContext('2d');
      const u = canvas.width / d.width;
      const css = canvas.getBoundingClientRect();
      out[id] = {
        width: d.width, height: d.height, cssWidth: css.width, cssHeight: css.height,
        labels: d.labels.map((l) => {
          const px = ctx.getImageData(Math.floor((l.x + 1.5) * u), Math.floor((l.y + l.h / 2) * u), 1, 1).data;
          return { ...l, background: [px[0], px[1], px[2]] };
        }),
      };
    }
    return out;
  });
}

function checkLabels(all, where) {
  for (const [id, c] of Object.entries(all)) {
    assert.ok(Math.abs(c.width - c.cssWidth) < 1 && Math.abs(c.height - c.cssHeight) < 1,
      `${where} ${id}: labels are in the canvas's CSS pixels (${c.width} x ${c.height} vs ${c.cssWidth} x ${c.cssHeight})`);
    c.labels.forEach((a, i) => {
      assert.ok(a.x >= 0 && a.y >= 0 && a.x + a.w <= c.width && a.y + a.h <= c.height,
        `${where} ${id}: label "${a.text}" leaves the canvas: ${JSON.stringify(a)}`);
      assert.ok(a.background.every((v) => v < 80), `${where} ${id}: no label background drawn under "${a.text}": ${a.background}`);
      c.labels.slice(i + 1).forEach((b) => {
        const w = Math.min(a.x + a.w, b.x + b.w) - Math.max(a.x, b.x);
        const h = Math.min(a.y + a.h, b.y + b.h) - Math.max(a.y, b.y);
        assert.ok(w <= 0 || h <= 0, `${where} ${id}: labels "${a.text}" and "${b.text}" overlap: ${JSON.stringify([a, b])}`);
      });
    });
  }
}

/** Every pairs-table cell (headers too) is one line and shows all its text;
 *  the table fits its panel without scrolling. */
async function checkTable(page, where) {
  const t = await page.evaluate(() => {
    const cells = [...document.querySelectorAll('[data-testid=pairs] th, [data-testid=pairs] tr[data-pair] td')];
    const box = document.querySelector('.pairs-box') || document.querySelector('[data-testid=pairs]').parentElement;
    return {
      box: [box.scrollWidth, box.clientWidth],
      cells: cells.map((el) => {
        const range = document.createRange();
        range.selectNodeContents(el);
        const tops = new Set([...range.getClientRects()].filter((r) => r.width > 0).map((r) => Math.round(r.top)));
        return { text: el.textContent, lines: tops.size, scroll: el.scrollWidth, client: el.clientWidth };
      }),
    };
  });
  for (const c of t.cells) {
    assert.ok(c.lines <= 1, `${where}: pairs-table cell "${c.text}" takes ${c.lines} lines`);
    assert.ok(c.scroll <= c.client, `${where}: pairs-table cell "${c.text}" is cut (${c.scroll} > ${c.client} px)`);
  }
  assert.ok(t.box[0] <= t.box[1], `${where}: the pairs table is wider than its panel (${t.box[0]} > ${t.box[1]} px)`);
  return t.cells.length;
}

for (const viewport of [{ width: 1280, height: 900 }, { width: 1440, height: 1100 }]) {
  const size = `${viewport.width} x ${viewport.height}`;
  test(`at ${size}: labels apart, table cells one line, status row and heightmaps steady`, async () => {
    const { context, page, errors } = await openPage(viewport);
    try {
      const start = await boxes(page);
      const said = new Set();
      let labelled = 0, cells = 0;
      const check = async (where) => {
        const labels = await drawnLabels(page);
        checkLabels(labels, where);
        labelled += Object.values(labels).reduce((a, c) => a + c.labels.length, 0);
        cells += await checkTable(page, where);
        sameBoxes(await boxes(page), start, where);
        said.add(await page.getByTestId('primitive').textContent());
      };
      for (let action = 1; action <= 2; action++) {
        for (const phase of ['embed', 'match', 'verify', 'act']) {
          await stepAndWait(page, 'next-phase');
          assert.equal(await page.evaluate(() => window.seespot.state.phase), phase);
          await check(`action ${action}, ${phase}`);
          if (phase === 'verify') {
            // Short headers, the unit and F's primitive explained in them.
            assert.equal(await page.getByTestId('c-head').textContent(), 'C (px²)');
            assert.match(await page.getByTestId('c-head').getAttribute('title'), /squared distance, in 2 mm heightmap pixels/);
            const s = await page.evaluate(() => window.seespot.state);
            assert.equal(await page.getByTestId('f-head').textContent(), `F (${s.decided_primitive})`);
            const f = s.pairs[0].matched;
            assert.equal(await page.locator('[data-testid=pairs] tbody tr[data-pair] td[data-testid=f]').first().textContent(),
              `r${f.rotation} (${f.y}, ${f.x})`);
            // A click-to-query right on the demonstrated action adds its
            // labels ("query", "best") beside the others.
            const fr = await page.evaluate(() => window.seespot.frame);
            const box = await page.getByTestId('demo-canvas').boundingBox();
            const n = fr.resolution, at = fr.demo.action;
            const q0 = await page.evaluate(() => window.seespot.lastQuery || null);
            await page.mouse.click(box.x + ((at.x + 0.5) * box.width) / n, box.y + ((at.y + 0.5) * box.height) / n);
            await page.waitForFunction((q) => window.seespot.lastQuery && window.seespot.lastQuery !== q
              && window.__seespotLabels['demo-canvas'].labels.some((l) => l.text === 'query'), q0);
            await check(`action ${action}, ${phase}, with a query`);
          }
        }
      }
      // Next action: a whole action at once, a few times (while the trial goes on).
      for (let k = 0; k < 4; k++) {
        if (await page.evaluate(() => window.seespot.state.end !== null)) break;
        await stepAndWait(page, 'next-action');
        await check(`next action ${k + 1}`);
      }
      // The labels and cells were there to check, and the "next" cell
      // changed its words (grasp, then place (holding)) without moving.
      assert.ok(labelled >= 20, `only ${labelled} labels drawn`);
      assert.ok(cells >= 50, `only ${cells} table cells`);
      assert.ok(said.has('grasp') && said.has('place (holding)'), `next said only ${[...said].join(', ')}`);
      assert.deepEqual(errors, []);
    } finally {
      await context.close();
    }
  });
}

test('while viewing history the embedding colours are off and say why; back to live they work', async () => {
  const { context, page, errors } = await openPage({ width: 1280, height: 900 });
  try {
    await stepAndWait(page, 'next-phase');
    await stepAndWait(page, 'next-phase');
    const box = page.getByTestId('show-embedding');
    assert.ok(await box.isEnabled());
    assert.ok(!(await page.getByTestId('embedding-note').isVisible()));
    const v0 = await page.evaluate(() => window.seespot.state.version);
    await page.$eval('[data-testid=timeline]', (el) => { el.value = '0'; el.dispatchEvent(new Event('input')); });
    await page.waitForFunction((v) => window.seespot.state.version > v && window.seespot.state.history.viewing === 0, v0);
    assert.ok(await box.isDisabled());
    assert.match(await page.getByTestId('embedding-note').textContent(), /live/);
    assert.ok(await page.getByTestId('embedding-note').isVisible());
    assert.match(await page.locator('#embedding-opt').getAttribute('title'), /live decision only/);
    await stepAndWait(page, 'go-live');
    assert.ok(await box.isEnabled());
    await box.check();
    await page.waitForFunction(() => document.body.dataset.embedding, null, { timeout: 60_000 });
    await box.uncheck();
    assert.deepEqual(errors, []);
  } finally {
    await context.close();
  }
});

test('a refused request is told in the user\'s words, not the protocol\'s', async () => {
  const { context, page } = await openPage({ width: 1280, height: 900 });
  try {
    const shown = async (send) => {
      const n = await page.evaluate(() => window.seespot.errors.length);
      await page.evaluate((m) => window.seespot.ws.send(JSON.stringify(m)), send);
      await page.waitForFunction((k) => window.seespot.errors.length > k, n);
      return page.getByTestId('error').textContent();
    };
    assert.equal(await shown({ type: 'reset', seed: 1.5 }), 'Reset: the seed must be a whole number, 0 or more');
    assert.match(await shown({ type: 'reset', task: 'juggle' }), /^Reset: there is no task "juggle"; choose stack, row/);
    assert.equal(await shown({ type: 'demo_undo' }), 'not demonstrating: press Demonstrate first');
    // The seed box is checked before anything is sent.
    await page.getByTestId('seed').fill('');
    await page.getByTestId('reset').click();
    assert.match(await page.getByTestId('error').textContent(), /^Reset: the seed must be a whole number/);
    // The glossary says what the table says about C.
    const glossary = await page.getByTestId('glossary').locator('dl').textContent();
    assert.match(glossary, /squared distance, in 2 mm heightmap pixels \(px², as in the pairs table\)/);
    assert.doesNotMatch(glossary, /in actions/);
  } finally {
    await context.close();
  }
});
