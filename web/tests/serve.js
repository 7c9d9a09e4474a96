// What the browser tests share: where the repository, the seespot binary and
// Chromium are, Chromium's flags, and starting / stopping `seespot view`.
import { spawn } from 'node:child_process';
import { existsSync, readFileSync } from 'node:fs';
import { gunzipSync } from 'node:zlib';
import { join, dirname, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

export const root = resolve(dirname(fileURLToPath(import.meta.url)), '..', '..');
export const BIN = process.env.SEESPOT_BIN || join(root, 'target', 'release', 'seespot');
export const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
export const FLAGS = ['--headless', '--no-sandbox', '--disable-gpu', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync'];

/**
 * The committed trial of `seed` in records file `path` (relative to the
 * repository root; gzip JSONL), or undefined.
 */
export function committedTrial(path, seed) {
  return gunzipSync(readFileSync(join(root, path))).toString('utf8').split('\n').filter(Boolean)
    .map((l) => JSON.parse(l)).find((r) => r.seed === seed);
}

/**
 * `seespot view --replay` of the committed trial of `seed` in records file
 * `path` (relative to the repository root), opened in Chromium:
 * `{ view, record }` ([`openView`]'s view, and the trial's record).
 */
export async function openReplay(path, seed) {
  if (!existsSync(BIN)) throw new Error(`no server binary at ${BIN}; build it with cargo build --release`);
  const record = committedTrial(path, seed);
  if (!record) throw new Error(`${path} has no trial of seed ${seed}`);
  const view = await openView(['view', '--port', '0', '--no-viewer', '--replay', path, '--seed', String(seed)]);
  return { view, record };
}

/**
 * Starts `$SEESPOT_BIN ARGS` (a `view`) from the repository root and resolves
 * once it has printed the page's URL (and the rerun web viewer's, with
 * `viewer`): `{ server, page, viewer, stderr() }`; `env` adds to its
 * environment. Rejects, with what it printed, when it exits first or prints
 * nothing in 120 s.
 */
export function startView(args, { viewer = false, env = {} } = {}) {
  return new Promise((ok, fail) => {
    const server = spawn(BIN, args, { cwd: root, stdio: ['ignore', 'pipe', 'pipe'], env: { ...process.env, ...env } });
    let out = '', err = '';
    const timer = setTimeout(() => fail(new Error(`seespot view printed no URL in 120 s:\n${out}\n${err}`)), 120_000);
    const check = () => {
      const page = (out + err).match(/seespot page:\s+(\S+)/);
      const view = (out + err).match(/rerun web viewer:\s+(\S+)/);
      if (page && (view || !viewer)) {
        clearTimeout(timer);
        ok({ server, page: page[1], viewer: view ? view[1] : null, stderr: () => err });
      }
    };
    server.stdout.on('data', (d) => { out += d.toString(); check(); });
    server.stderr.on('data', (d) => { err += d.toString(); check(); });
    server.on('exit', (code) => { clearTimeout(timer); fail(new Error(`seespot view exited with ${code}:\n${out}\n${err}`)); });
  });
}

/** Ends a server with Ctrl-C (SIGINT) and waits for it; nothing if it has exited. */
export async function stopView(server) {
  if (server && server.exitCode === null) {
    const exited = new Promise((r) => server.once('exit', r));
    server.kill('SIGINT');
    await exited;
  }
}

// The page's files as the server serves them (app/viz/src/server.rs ASSETS,
// embedded in the binary when it is built): url path -> [file in web/, type].
const ASSETS = {
  '/': ['index.html', 'text/html; charset=utf-8'],
  '/index.html': ['index.html', 'text/html; charset=utf-8'],
  '/app.js': ['app.js', 'text/javascript; charset=utf-8'],
  '/render.js': ['render.js', 'text/javascript; charset=utf-8'],
  '/style.css': ['style.css', 'text/css; charset=utf-8'],
  '/review': ['review.html', 'text/html; charset=utf-8'],
  '/review.js': ['review.js', 'text/javascript; charset=utf-8'],
  '/difference': ['difference.html', 'text/html; charset=utf-8'],
  '/difference.js': ['difference.js', 'text/javascript; charset=utf-8'],
  '/favicon.svg': ['favicon.svg', 'image/svg+xml'],
};

/** Whether the tests serve the page's files from web/ (SEESPOT_WEB_FROM_DISK=1). */
export const WEB_FROM_DISK = process.env.SEESPOT_WEB_FROM_DISK === '1';

/**
 * With SEESPOT_WEB_FROM_DISK=1: a proxy on 127.0.0.1 in front of the server
 * at `pageUrl` that answers the page's own files (index.html, app.js,
 * render.js, style.css, review.*, difference.*) from web/ on disk and passes every other
 * request, the WebSocket included, to the server (with its `Host` and
 * `Origin`). For trying page changes against a prebuilt server, which embeds
 * the files it was built with. Resolves to `{ url, close() }`: `url` is
 * `pageUrl` on the proxy; without the variable, `pageUrl` itself.
 */
export async function pageFromDisk(pageUrl) {
  if (!WEB_FROM_DISK) return { url: pageUrl, close: async () => {} };
  const http = await import('node:http');
  const net = await import('node:net');
  const { readFileSync } = await import('node:fs');
  const target = new URL(pageUrl);
  const port = Number(target.port);
  const sockets = new Set();
  // The request's raw headers with the server's own Host and Origin.
  const rewrite = (raw) => {
    const out = [];
    for (let i = 0; i < raw.length; i += 2) {
      const k = raw[i].toLowerCase();
      out.push(raw[i], k === 'host' ? target.host : k === 'origin' ? target.origin : raw[i + 1]);
    }
    return out;
  };
  const proxy = http.createServer((req, res) => {
    const asset = ASSETS[new URL(req.url, 'http://x').pathname];
    if (asset && (req.method === 'GET' || req.method === 'HEAD')) {
      res.writeHead(200, { 'content-type': asset[1], 'cache-control': 'no-store' });
      res.end(req.method === 'HEAD' ? undefined : readFileSync(join(root, 'web', asset[0])));
      return;
    }
    const up = http.request({ host: target.hostname, port, method: req.method, path: req.url, headers: rewrite(req.rawHeaders) }, (r) => {
      res.writeHead(r.statusCode, r.headers);
      r.pipe(res);
    });
    up.on('error', () => res.destroy());
    req.pipe(up);
  });
  proxy.on('upgrade', (req, socket, head) => {
    sockets.add(socket);
    socket.on('close', () => sockets.delete(socket));
    const up = net.connect(port, target.hostname, () => {
      const raw = rewrite(req.rawHeaders);
      let text = `${req.method} ${req.url} HTTP/1.1\r\n`;
      for (let i = 0; i < raw.length; i += 2) text += `${raw[i]}: ${raw[i + 1]}\r\n`;
      up.write(`${text}\r\n`);
      if (head.length) up.write(head);
      up.pipe(socket); socket.pipe(up);
    });
    sockets.add(up);
    up.on('close', () => { sockets.delete(up); socket.destroy(); });
    up.on('error', () => socket.destroy());
    socket.on('error', () => up.destroy());
  });
  await new Promise((ok) => proxy.listen(0, '127.0.0.1', ok));
  const url = new URL(pageUrl);
  url.host = `127.0.0.1:${proxy.address().port}`;
  return {
    url: url.toString(),
    close: () => new Promise((ok) => {
      for (const s of sockets) s.destroy();
      proxy.closeAllConnections();
      proxy.close(() => ok());
    }),
  };
}

/** The page's files the server at `pageUrl` serves that differ from web/'s
 *  on disk (none when they are served from disk). */
export async function pageFilesDiffering(pageUrl) {
  const { readFileSync } = await import('node:fs');
  const differing = [];
  for (const path of ['/app.js', '/render.js', '/style.css', '/index.html']) {
    const served = await (await fetch(new URL(path, pageUrl))).text();
    if (served !== readFileSync(join(root, 'web', ASSETS[path][0]), 'utf8')) differing.push(path);
  }
  return differing;
}

/**
 * Starts `$SEESPOT_BIN ARGS` (a `view`) and opens its page in headless
 * Chromium (1500 x 1150, a fresh profile in a temporary folder, the page's
 * files from disk with SEESPOT_WEB_FROM_DISK=1), once the page has its
 * first state. Resolves to `{ server, pageUrl, page, errors, stepAndWait,
 * close() }`: `errors` collects the page's script errors; `stepAndWait(id)`
 * clicks the control with that test id and waits until the page has drawn
 * the state it leads to. `env` adds to the server's environment.
 */
export async function openView(args, { env = {} } = {}) {
  const { chromium } = await import('playwright-core');
  const { mkdtempSync, rmSync } = await import('node:fs');
  const { tmpdir } = await import('node:os');
  const tmp = mkdtempSync(join(tmpdir(), 'seespot-view-'));
  const { server, page: served } = await startView(args, { env });
  const proxy = await pageFromDisk(served);
  const context = await chromium.launchPersistentContext(join(tmp, 'profile'), {
    executablePath: CHROMIUM, headless: true, args: FLAGS, viewport: { width: 1500, height: 1150 },
  });
  const page = await context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  await page.goto(proxy.url);
  await page.waitForFunction(() => window.seespot && window.seespot.state && window.seespot.frameVersion >= 0);
  const stepAndWait = async (testid) => {
    const v0 = await page.evaluate(() => window.seespot.state.version);
    await page.getByTestId(testid).click();
    await page.waitForFunction((v) => window.seespot.state.version > v
      && window.seespot.frameVersion === window.seespot.state.version, v0, { timeout: 120_000 });
  };
  const close = async () => {
    await context.close();
    await proxy.close();
    await stopView(server);
    rmSync(tmp, { recursive: true, force: true });
  };
  return { server, pageUrl: proxy.url, page, errors, stepAndWait, close };
}
