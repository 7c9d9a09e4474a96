// What the browser tests share: where the repository, the seespot binary and
// Chromium are, Chromium's flags, and starting / stopping `seespot view`.
import { spawn } from 'node:child_process';
import { join, dirname, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

export const root = resolve(dirname(fileURLToPath(import.meta.url)), '..', '..');
export const BIN = process.env.SEESPOT_BIN || join(root, 'target', 'release', 'seespot');
export const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
export const FLAGS = ['--headless', '--no-sandbox', '--disable-gpu', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync'];

/**
 * Starts `$SEESPOT_BIN ARGS` (a `view`) from the repository root and resolves
 * once it has printed the page's URL (and the rerun web viewer's, with
 * `viewer`): `{ server, page, viewer, stderr() }`. Rejects, with what it
 * printed, when it exits first or prints nothing in 120 s.
 */
export function startView(args, { viewer = false } = {}) {
  return new Promise((ok, fail) => {
    const server = spawn(BIN, args, { cwd: root, stdio: ['ignore', 'pipe', 'pipe'] });
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
