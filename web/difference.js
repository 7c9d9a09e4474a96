// Two runs side by side (`/difference?a=RUN&b=RUN&task=T&seed=S`): both
// trials of one seed, replayed up to the first action where they chose
// differently, shown as the debugger shows one trial (heightmaps, the pairs
// table with L and C, the match and rematch arrows), with each side's chosen
// pair highlighted. One slider moves both sides through the actions they
// shared, up to the one where they part.
import { b64bytes, b64f32, rgbCanvas, heatCanvas, compose, truthCell, truthWords } from './render.js';

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
const pairing = { a: params.get('a'), b: params.get('b'), task: params.get('task'), seed: params.get('seed') };

// Exposed for the browser tests: the document, each side's view, errors.
const diff = window.seespotDifference = { doc: null, views: { a: null, b: null }, action: null, errors: [] };

function showError(msg) {
  diff.errors.push(msg);
  const e = $('error');
  e.textContent = msg; e.hidden = false;
}

function fmt(v, d) { return v === null || v === undefined ? '…' : Number(v).toFixed(d); }
function act(a) { return a ? `${a.primitive} r${a.rotation} (${a.y}, ${a.x})` : '—'; }
function same(x, y) { return !!x && !!y && x.primitive === y.primitive && x.rotation === y.rotation && x.y === y.y && x.x === y.x; }
const C_UNITS = { squared_reference_pixels: 'px²', pixels: 'px' };

function query(extra) {
  return new URLSearchParams({ ...pairing, ...extra });
}

// One side's column, built once: title, outcome, the two heightmaps, the table.
function buildSide(side, run) {
  const el = document.querySelector(`.diff-side[data-side=${side}]`);
  el.innerHTML = `
    <h2><span class="diff-run">${side.toUpperCase()} · </span><span data-testid="run"></span>
      <small data-testid="outcome"></small></h2>
    <p class="diff-choice" data-testid="choice"></p>
    <div class="diff-maps">
      <figure><canvas data-testid="demo-canvas"></canvas><figcaption data-testid="demo-title"></figcaption></figure>
      <figure><canvas data-testid="live-canvas"></canvas><figcaption>live scene, the match map of the shown pair</figcaption></figure>
    </div>
    <table class="pairs"><thead><tr><th></th><th>policy</th><th>demo·step</th><th title="L: match distance (Eq. 4)">L</th>
      <th data-testid="c-head">C</th><th>F</th><th title="the simulator's truth about F, worked out on a copy of the world: ✓ right, ✗ wrong (the tooltip says why)">✓?</th></tr></thead><tbody data-testid="pairs"></tbody></table>
    <p class="hint" data-testid="decider"></p>`;
  el.querySelector('[data-testid=run]').textContent = run.run;
  const out = el.querySelector('[data-testid=outcome]');
  out.textContent = `${run.success ? 'succeeded' : 'failed'} in ${run.actions} actions`;
  out.className = run.success ? 'ok' : 'refused';
  el.querySelector('[data-testid=decider]').textContent = run.decider;
  return el;
}

async function fetchView(side, action, pair) {
  const extra = { side, action: String(action) };
  if (pair !== undefined && pair !== null) extra.pair = String(pair);
  const r = await fetch(`/api/difference/view?${query(extra)}`);
  if (!r.ok) throw new Error(await r.text());
  return r.json();
}

function drawSide(side, v) {
  const el = document.querySelector(`.diff-side[data-side=${side}]`);
  const s = v.state, f = v.frame, n = f.resolution;
  const p = s.pairs[f.pair];
  const taken = s.steps[v.action] ? s.steps[v.action].action : null;
  const other = diff.views[side === 'a' ? 'b' : 'a'];
  const otherTaken = other && other.state.steps[other.action] ? other.state.steps[other.action].action : null;
  const choice = el.querySelector('[data-testid=choice]');
  choice.textContent = `action ${v.action + 1}: ${act(taken)}`
    + (v.action < diff.action ? ' (ended here)' : '')
    + (p && s.chosen === f.pair ? ` · pair ${p.policy} ${p.demo}·${p.demo_step}, L ${fmt(p.l, 3)}, C ${fmt(p.c, 1)}` : '')
    + (p && s.chosen === f.pair && p.truth ? ` · ${truthWords(p.truth)}` : '');
  choice.classList.toggle('parts', !!otherTaken && !same(taken, otherTaken));
  // Demo side: the demonstrated action, and F -> rematch.
  const dm = [];
  if (p) {
    dm.push({ kind: 'point', at: p.demo_action, color: '#ffffff', label: `demo ${act(p.demo_action)}`, ring: true });
    if (p.matched && p.rematch) dm.push({ kind: 'arrow', from: p.matched, to: p.rematch, color: '#ffaa00', label: `C = ${fmt(p.c, 1)}` });
  }
  const demoBase = f.demo ? rgbCanvas(b64bytes(f.demo.color), n) : null;
  const rematch = f.rematch_map ? heatCanvas(b64f32(f.rematch_map), n).canvas : null;
  compose(el.querySelector('[data-testid=demo-canvas]'), n, demoBase, rematch, 0.45, dm);
  el.querySelector('[data-testid=demo-title]').textContent = f.demo ? `demo ${f.demo.demo} · step ${f.demo.step}, the rematch map` : 'no demonstration (this run has no pairs)';
  // Live side: the demo action -> F, the executed action.
  const lm = [];
  const chosen = s.chosen === f.pair;
  if (p && p.matched) lm.push({ kind: 'arrow', from: p.demo_action, to: p.matched, color: chosen ? '#00e676' : '#ffffff', label: `L = ${fmt(p.l, 3)}` });
  if (taken) lm.push({ kind: 'point', at: taken, color: '#00e676', label: 'executed', ring: true });
  const live = rgbCanvas(b64bytes(f.live.color), n);
  const match = f.match_map ? heatCanvas(b64f32(f.match_map), n).canvas : null;
  compose(el.querySelector('[data-testid=live-canvas]'), n, live, match, 0.45, lm);
  // The pairs table: the chosen pair starred, the shown one selected.
  const head = el.querySelector('[data-testid=c-head]');
  if (s.pairs.length) head.textContent = `C (${C_UNITS[s.pairs[0].c_unit] || '?'})`;
  const body = el.querySelector('[data-testid=pairs]');
  const rows = s.pairs.map((q, i) => {
    const tr = document.createElement('tr');
    if (i === s.chosen) tr.classList.add('chosen');
    if (i === f.pair) tr.classList.add('selected');
    for (const c of [i === s.chosen ? '★' : '', q.policy, `${q.demo}·${q.demo_step}`, fmt(q.l, 3), fmt(q.c, 1), q.matched ? `r${q.matched.rotation} (${q.matched.y}, ${q.matched.x})` : '…']) {
      const td = document.createElement('td'); td.textContent = c; tr.appendChild(td);
    }
    const td = document.createElement('td');
    td.textContent = truthCell(q);
    td.dataset.testid = 'truth';
    if (q.truth) { td.className = q.truth.verdict === 'right' ? 'right' : 'wrong'; td.title = truthWords(q.truth); }
    tr.appendChild(td);
    tr.onclick = () => show(side, diff.action, i);
    return tr;
  });
  if (!rows.length) {
    const tr = document.createElement('tr');
    tr.innerHTML = '<td colspan="7" class="pending">this run\'s decider gives no pairs</td>';
    rows.push(tr);
  }
  body.replaceChildren(...rows);
}

async function show(side, action, pair) {
  const v = await fetchView(side, action, pair);
  diff.views[side] = v;
  drawSide(side, v);
}

// Both sides at `action` (their chosen pairs).
async function goto(action) {
  const d = diff.doc;
  action = Math.max(d.first_kept, Math.min(d.first_difference, action));
  diff.action = action;
  $('timeline').value = String(action);
  $('at').textContent = action === d.first_difference
    ? `action ${action + 1}: where the two part`
    : `action ${action + 1} of ${d.first_difference + 1}: the same on both sides`;
  try {
    const [va, vb] = await Promise.all([fetchView('a', action), fetchView('b', action)]);
    if (diff.action !== action) return; // superseded
    diff.views = { a: va, b: vb };
    drawSide('a', va); drawSide('b', vb);
    document.body.dataset.action = String(action);
  } catch (e) { showError(String(e.message || e)); }
}

async function load() {
  for (const k of ['a', 'b', 'task', 'seed']) {
    if (!pairing[k]) { showError(`the address names no ${k}: open this view from the review page`); return; }
  }
  const r = await fetch(`/api/difference?${query({})}`);
  if (!r.ok) { showError(await r.text()); $('conn').textContent = 'cannot compare'; return; }
  const d = await r.json();
  diff.doc = d;
  $('conn').textContent = `parts at action ${d.first_difference + 1}`; $('conn').className = 'conn ok';
  $('title').textContent = `${d.a.run} against ${d.b.run} · ${d.task} seed ${d.seed}`;
  const n = d.first_difference;
  $('summary').textContent = (n === 0 ? 'They part at their first action: ' : `Both took the same first ${n === 1 ? 'action' : `${n} actions`}; at action ${n + 1} `)
    + `${d.a.run} took ${act(d.a.chosen)} and ${d.b.run} took ${act(d.b.chosen)}. `
    + `${d.a.success ? d.a.run : d.b.run} succeeded in the end, ${d.a.success ? d.b.run : d.a.run} failed.`;
  buildSide('a', d.a); buildSide('b', d.b);
  const t = $('timeline');
  t.min = String(d.first_kept); t.max = String(d.first_difference);
  t.oninput = () => goto(Number(t.value));
  $('prev').onclick = () => goto(diff.action - 1);
  $('next').onclick = () => goto(diff.action + 1);
  document.addEventListener('keydown', (e) => {
    if (e.key === 'ArrowLeft') goto(diff.action - 1);
    if (e.key === 'ArrowRight') goto(diff.action + 1);
  });
  await goto(d.first_difference);
}

load().catch((e) => showError(String(e)));
