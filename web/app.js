// The seespot page: a WebSocket client that steps the trial and draws each
// (policy, demo) pair's match and rematch. No build step, no dependencies.
import { b64bytes, b64f32, rgbCanvas, depthCanvas, heatCanvas, compose, pixelAt, truthCell, truthWords } from './render.js';

const $ = (id) => document.getElementById(id);
const PHASES = ['embed', 'match', 'verify', 'act'];

// Exposed for the browser tests and for poking around in the console.
const app = window.seespot = {
  info: null, state: null, frame: null, frameVersion: -1, query: null,
  selectedPair: null, errors: [], ws: null,
  // Demonstrate mode: the gripper's rotation index (0..15) and the pixel under the mouse.
  demoRotation: 0, hover: null, saved: null,
};
const ROTATIONS = 16;

let pending = null; // frame request in flight
let images = { live: null, demo: null, match: null, rematch: null, query: null, embedding: null };

function send(msg) {
  if (app.ws && app.ws.readyState === WebSocket.OPEN) app.ws.send(JSON.stringify(msg));
  else showError('not connected to the seespot server');
}

function connect() {
  const ws = new WebSocket(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`);
  app.ws = ws;
  ws.onopen = () => { $('conn').textContent = 'connected'; $('conn').className = 'conn ok'; };
  ws.onclose = () => {
    $('conn').textContent = 'disconnected'; $('conn').className = 'conn bad';
    setTimeout(connect, 1000);
  };
  ws.onmessage = (ev) => {
    let m;
    try { m = JSON.parse(ev.data); } catch { return; }
    if (m.type === 'info') onInfo(m.info);
    else if (m.type === 'state') onState(m);
    else if (m.type === 'query') onQuery(m);
    else if (m.type === 'error') showError(m.message, m.request, m.kind);
    else if (m.type === 'busy') onBusy(m);
    else if (m.type === 'demo_saved') {
      app.saved = m.dir; renderDemoStatus(app.state);
      // A custom task can be run once it has a demonstration.
      const t = $('demo-task').value.trim();
      if (t.startsWith('custom:')) addTask(t);
    }
  };
}

/** Long work on the server (protocol.rs `Busy`): what, why and for how
 *  long so far; gone when `what` is null. The page stays usable. */
function onBusy(m) {
  app.busy = m.what ? m : null;
  const el = $('busy');
  el.hidden = !m.what;
  if (m.what) setText(el, `⏳ Preparing ${m.what}: ${m.seconds} s so far${m.why ? `. ${m.why}` : ''}`);
}

// What each kind of failure is (protocol.rs `ServerMessage::Error.kind`),
// said before the message; a refused request's words stand alone.
const KIND_WORDS = {
  files: 'A model, demonstration or records file could not be used',
  decide: 'The decision failed',
  recording: 'The recording failed',
};

/** Shows an error in the user's words (`userWords`), after what kind of
 *  failure it is; `app.errors` keeps the server's own message, for the tests
 *  and the console. */
function showError(msg, request, kind) {
  app.errors.push(msg);
  app.errorKinds = [...(app.errorKinds || []), kind || 'request'];
  const plain = userWords(msg, request);
  const words = KIND_WORDS[kind] ? `${KIND_WORDS[kind]}: ${plain}` : plain;
  app.shownErrors = [...(app.shownErrors || []), words];
  const e = $('error');
  e.textContent = words; e.title = words === msg ? 'click to dismiss' : `the server said: ${msg} (click to dismiss)`; e.hidden = false;
  clearTimeout(showError.t);
  showError.t = setTimeout(() => { e.hidden = true; }, 8000);
}
$('error').onclick = () => { $('error').hidden = true; };

// What each request is, in the page's words.
const REQUEST_WORDS = {
  reset: 'Reset', demonstrate: 'Demonstrate', demo_act: 'the demonstrated action', demo_undo: 'Undo',
  demo_save: 'Save', demo_stop: 'Leave', goto: 'the history slider', live: 'Live', query: 'the click-to-query',
  next_phase: 'Next phase', next_action: 'Next action', run: 'Run to end', replay: 'the replay', set_blocks: 'the layout edit',
};
// The whole numbers each request carries, by request.
const NUMBER_WORDS = {
  reset: 'the seed must be a whole number, 0 or more',
  demonstrate: 'the seed must be a whole number, 0 or more',
  replay: 'the seed must be a whole number, 0 or more',
  goto: 'the history position must be a whole number, 0 or more',
  query: 'the queried pixel must be whole numbers inside the heightmap',
};
const TASKS_WORDS = 'stack, row, unstack or vertical-square, or custom:NAME for a task you demonstrated';

/** The server's error message in the user's words: the names of the
 *  protocol (message types, field names, serde's "expected u64") replaced by
 *  what the user did. Messages already in plain words pass through. */
export function userWords(msg, request) {
  if (typeof msg !== 'string') return String(msg);
  let m = msg.match(/^malformed message \(not JSON\)/);
  if (m) return 'the page sent the server something it could not read (not JSON); reload the page';
  m = msg.match(/^message has no string field `type`/);
  if (m) return 'the page sent the server a request it could not read; reload the page';
  m = msg.match(/^bad `([a-z_]+)` message: (.*)$/s);
  if (m) {
    const [, kind, rest] = m;
    const what = REQUEST_WORDS[kind] || kind;
    if (/^unknown variant `/.test(rest)) return `the server does not know the request "${kind}"; reload the page (the server may be newer than it)`;
    if (/^invalid (type|value): .*expected (u64|usize|u32|u8|i64|a nonnegative integer)/.test(rest)) {
      return NUMBER_WORDS[kind] ? `${what}: ${NUMBER_WORDS[kind]}` : `${what}: a number must be a whole number, 0 or more`;
    }
    let t = rest.match(/^unknown task '(.*?)'/);
    if (t) return t[1] === '' ? `${what}: name a task (${TASKS_WORDS})` : `${what}: there is no task "${t[1]}"; choose ${TASKS_WORDS}`;
    t = rest.match(/^task name '(.*?)' must be/);
    if (t) return `${what}: "${t[1]}" cannot be a custom task's name: use 1 to 48 lowercase letters, digits and '-' (the name is a folder under demos/custom, so no '/' or '..')`;
    t = rest.match(/^missing field `(\w+)`/);
    if (t) return `${what}: the request lacks its ${t[1]}; reload the page`;
    return `${what} was refused: ${rest}`;
  }
  if (/^not demonstrating: send `demonstrate` first/.test(msg)) return 'not demonstrating: press Demonstrate first';
  m = msg.match(/^colours_matter: only a custom task's goal is a layout; (.*) has its own rule/);
  if (m) return `"colours matter" is for custom tasks only: ${m[1]} has its own goal; untick it or name a custom:NAME task`;
  m = msg.match(/^history index (\d+) is out of range: this trial has shown (\d+) phases/);
  if (m) return `there is no point ${m[1]} in the history: this trial has shown ${m[2]} phases so far`;
  if (/^no decision yet: step to the embed phase first/.test(msg)) return 'nothing decided yet: press Next phase to embed the scene first';
  m = msg.match(/^action (\w+) r\d+ \((\d+), (\d+)\): pixel \(\d+, \d+\) is outside the (\d+) x \d+ workspace heightmap/);
  if (m) return `pixel (${m[2]}, ${m[3]}) is outside the ${m[4]} x ${m[4]} heightmap: click inside it`;
  m = msg.match(/^action \w+ r\d+ \(\d+, \d+\): the next action must be a (\w+)/);
  if (m) return `the next action must be a ${m[1]}: grasps and places alternate`;
  return msg;
}

function onInfo(info) {
  app.info = info;
  const sel = $('task');
  if (!sel.options.length) for (const t of info.tasks) sel.add(new Option(t, t));
  const dl = $('demo-tasks');
  if (!dl.options.length) for (const t of info.tasks) dl.appendChild(new Option(t, t));
  if (info.viewer_url) { $('viewer-link').href = info.viewer_url; }
  else {
    $('viewer-link').hidden = true; $('toggle-viewer').hidden = true;
    if (!info.recordings) $('viewer-note').hidden = false;
  }
}

/** Adds a task (a custom one) to the task box, once. */
function addTask(t) {
  const sel = $('task');
  if (![...sel.options].some((o) => o.value === t)) sel.add(new Option(t, t));
}

function fmt(v, d) { return v === null || v === undefined ? '…' : Number(v).toFixed(d); }
function act(a) { return a ? `${a.primitive} r${a.rotation} (${a.y}, ${a.x})` : '…'; }
/** An action without its primitive (the pairs table names it in F's header). */
function where(a) { return a ? `r${a.rotation} (${a.y}, ${a.x})` : '…'; }
/** Sets a cell's text, with the whole text as its tooltip (it may be cut short). */
function setText(el, text) { el.textContent = text; el.title = text; }

function onState(s) {
  const prev = app.state;
  app.state = s;
  if (!prev || prev.task !== s.task || prev.seed !== s.seed || prev.trial_index !== s.trial_index) {
    addTask(s.task);
    $('task').value = s.task; $('seed').value = s.seed;
  }
  if (app.selectedPair !== null && app.selectedPair >= s.pairs.length) app.selectedPair = null;
  if (prev && prev.version !== s.version && (prev.action_index !== s.action_index || s.phase === 'embed')) clearQuery(false);

  // Pipeline.
  const k = PHASES.indexOf(s.phase);
  for (const li of $('pipeline').children) {
    const i = PHASES.indexOf(li.dataset.phase);
    li.className = i === k ? 'current' : (i < k ? 'done' : '');
  }
  $('action-index').textContent = String(s.action_number);
  $('progress').textContent = `${s.progress} / 4`;
  $('progress-bar').style.width = `${(s.progress / 4) * 100}%`;
  $('primitive').textContent = s.holding !== null ? `place (holding)` : s.primitive;
  if (s.end) app.running = false;
  renderEnd(s);
  $('method').textContent = s.method ? s.method.toUpperCase() : '';
  $('decider').textContent = (s.replay ? `${s.replay[0].toUpperCase()}${s.replay.slice(1)}. ` : '')
    + `${s.decider}. ${s.decider_note}` + (s.recording ? ` Recording to ${s.recording}.` : '');
  $('replay-banner').hidden = !s.replay;
  $('replay-banner').textContent = s.replay ? `▶ ${s.replay}` : '';
  renderFailure(s);
  const ended = !!s.end;
  const demo = s.demonstrate;
  for (const id of ['next-phase', 'next-action', 'run']) $(id).disabled = ended || !!demo;
  document.body.classList.toggle('demonstrating', !!demo);
  $('demo-live').hidden = !demo;
  if (demo) {
    $('demo-undo').disabled = !demo.actions.length;
    // Nothing to save before the first action.
    $('demo-save').disabled = !demo.actions.length;
    $('demo-save').title = demo.actions.length ? 'save the demonstration' : 'nothing to save yet: click the live heightmap to act';
    $('progress').textContent = demo.progress !== null ? `${demo.progress} / 4` : '–';
    $('progress').title = demo.progress !== null ? '' : 'a custom task\'s goal is its final layout: progress is known once it is saved';
    $('progress-bar').style.width = `${((demo.progress ?? 0) / 4) * 100}%`;
    $('action-index').textContent = String(demo.actions.length);
  } else $('progress').title = '';
  renderDemoStatus(s);

  // Query policies.
  const qp = $('query-policy');
  if (qp.options.length !== s.policies.length) {
    qp.innerHTML = '';
    s.policies.forEach((p, i) => qp.add(new Option(p, String(i))));
  }

  renderPairs(s);
  renderHistory(s);
  renderTimeline(s);
  renderEmbeddingControl(s);
  if (s.error) showError(s.error);
  requestFrame();
}

/** The trial box: how a finished trial ended, a failure in the review's
 *  words (documents.rs `FailureDoc`), with how the trial ended as its tooltip. */
function renderEnd(s) {
  const el = $('end');
  if (s.demonstrate) { setText(el, 'demonstrating'); return; }
  if (!s.end) { setText(el, app.running ? 'in progress, running…' : 'in progress'); return; }
  if (s.succeeded) { setText(el, 'success ✓'); return; }
  const words = s.failure ? `failed: ${s.failure.label}` : s.end_words;
  el.textContent = words;
  el.title = s.failure ? `${words} (as seespot review files it; the trial ${s.end_words.replace(/^failed: /, 'ended: ')})` : words;
}

/** Why a finished trial failed, and for a known failure of the paper's
 *  method the same trial with seespot's extensions (one click, or the
 *  command). The server decides both; the page only words them. */
function renderFailure(s) {
  const f = !s.demonstrate && s.end && !s.succeeded ? s.failure : null;
  const box = $('failure-box');
  box.hidden = !f;
  if (!f) return;
  $('failure-kind').textContent = `Trial failed: ${f.label}.`;
  $('failure-known').textContent = f.known || '';
  const x = f.extensions;
  $('failure-offer').hidden = !x;
  if (!x) return;
  const button = $('try-extensions');
  button.hidden = !x.replay;
  button.textContent = `▶ The same trial with seespot's extensions${x.outcome ? ` (${x.outcome})` : ''}`;
  button.title = `${x.label}: ${x.task} seed ${x.seed}, replayed from the review`;
  button.onclick = () => send({ type: 'replay', method: x.run, task: x.task, seed: x.seed });
  $('extensions-or').textContent = x.replay ? 'or from a shell:' : `${x.label} on this trial, from a shell:`;
  $('extensions-command').textContent = x.command;
}

function shownPair() {
  const s = app.state;
  if (!s || !s.pairs.length) return 0;
  if (app.selectedPair !== null) return app.selectedPair;
  return s.chosen ?? 0;
}

// C with its unit (documents.rs `PairDoc.c_unit`): squared 2 mm pixels with
// the reference Correspond, heightmap pixels with the plain scan. Short, with
// the unit in words for the header's tooltip.
const C_UNITS = { squared_reference_pixels: 'px²', pixels: 'px' };
const C_UNIT_WORDS = {
  squared_reference_pixels: 'squared distance, in 2 mm heightmap pixels, between the rematch and the demonstrated action',
  pixels: 'distance, in heightmap pixels, between the rematch and the demonstrated action',
};
function cValue(p) {
  return p.c == null ? fmt(p.c, 1) : `${fmt(p.c, 1)} ${C_UNITS[p.c_unit] || ''}`.trim();
}

function renderPairs(s) {
  const body = $('pairs-body');
  body.innerHTML = '';
  const cHead = document.getElementById('c-head');
  if (cHead && s.pairs.length) {
    const u = s.pairs[0].c_unit;
    cHead.textContent = `C (${C_UNITS[u] || '?'})`;
    cHead.title = `C: cycle-consistency distance (Eq. 7): the ${C_UNIT_WORDS[u] || 'distance between the rematch and the demonstrated action'}; smaller is better`;
  }
  // F's primitive is the decision's, the same for every pair: it goes in the header.
  const fHead = $('f-head');
  const prim = s.decided_primitive || (s.pairs.find((p) => p.matched) || {}).matched?.primitive;
  fHead.textContent = prim ? `F (${prim})` : 'F';
  const sel = shownPair();
  s.pairs.forEach((p, i) => {
    const tr = document.createElement('tr');
    tr.dataset.pair = String(i);
    if (i === s.chosen) tr.classList.add('chosen');
    if (i === sel) tr.classList.add('selected');
    const picks = [s.ccd_choice === i ? 'CCD' : '', s.l2cd_choice === i ? 'L2CD' : ''].filter(Boolean).join(' ');
    const cells = [i === s.chosen ? '★' : '', p.policy, `${p.demo}·${p.demo_step}`, fmt(p.l, 3), fmt(p.c, 1), where(p.matched), picks, truthCell(p)];
    cells.forEach((c, j) => {
      const td = document.createElement('td');
      td.textContent = c;
      if (c === '…') td.className = 'pending';
      if (j === 3) td.dataset.testid = 'l'; if (j === 4) td.dataset.testid = 'c';
      if (j === 5 && p.matched) { td.dataset.testid = 'f'; td.title = `F: ${act(p.matched)} (rotation index, pixel y, x)`; }
      if (j === 6) { td.dataset.testid = 'picks'; td.className = 'picks'; }
      if (j === 7) {
        td.dataset.testid = 'truth';
        if (p.truth) { td.className = p.truth.verdict === 'right' ? 'right' : 'wrong'; td.title = truthWords(p.truth); }
      }
      tr.appendChild(td);
    });
    tr.onclick = () => { app.selectedPair = i; renderPairs(app.state); requestFrame(true); };
    body.appendChild(tr);
  });
  const pick = (k) => (k === null || k === undefined || !s.pairs[k] ? '…' : act(s.pairs[k].matched));
  $('method-choices').textContent = !s.pairs.length ? ''
    : s.method === 'transporter'
      ? 'TransporterNet: the match map is its score map for this primitive (best score minus score: 0 at the action, larger is worse); no rematch.'
      : s.method === 'spot-q'
        ? 'SPOT-Q: the match map is the policy\'s Q map for this primitive at the chosen rotation (best Q minus Q: 0 at the action, larger is worse); no demonstrations, no rematch.'
      : `On this state SSR CCD would take ${pick(s.ccd_choice)}; SSR L2CD would take ${pick(s.l2cd_choice)}.`;
  // The shown pair's F, judged by the simulator.
  const shown = s.pairs[sel];
  $('truth-line').hidden = !(shown && shown.truth);
  $('truth-line').textContent = shown && shown.truth ? `Truth: F of ${shown.policy} · demo ${shown.demo} is ${truthWords(shown.truth)}.` : '';
  // Where an extension of SSR departed from SSR CCD: the actions it masked, and why.
  const skipped = s.skipped || [];
  $('departures').hidden = !skipped.length;
  $('departures').textContent = skipped.map((k) => {
    const cm = +(k.radius_m * 100).toFixed(1);
    return k.outside
      ? `Extension: every ${k.action.primitive} but the ${cm} cm around (${k.action.y}, ${k.action.x}) skipped: ${k.why}.`
      : `Extension: ${act(k.action)} and the ${cm} cm around it skipped: ${k.why}.`;
  }).join(' ');
  if (!s.pairs.length) {
    const tr = document.createElement('tr');
    tr.innerHTML = `<td colspan="8" class="pending">${s.phase ? 'this decider gives no explanation' : 'step to the embed phase'}</td>`;
    body.appendChild(tr);
  }
}

function renderHistory(s) {
  const ol = $('history');
  ol.innerHTML = '';
  for (const st of s.steps) {
    const li = document.createElement('li');
    li.className = !st.success ? 'fail' : (st.progress_after > st.progress_before ? 'up' : '');
    li.innerHTML = `<b>${act(st.action)}</b> ${st.success ? 'ok' : 'failed'} · progress ${st.progress_before} → ${st.progress_after}${st.reversal ? ' · reversal' : ''}`;
    ol.appendChild(li);
  }
}

// Time travel: one slider position per phase shown in this trial.
function actionLabel(at) { return `action ${at.action_number} · ${at.phase}`; }

function renderTimeline(s) {
  const h = s.history || { len: 0, viewing: null, phases: [] };
  const t = $('timeline');
  t.max = String(Math.max(0, h.len - 1));
  t.disabled = h.len === 0;
  if (document.activeElement !== t) t.value = String(h.viewing ?? Math.max(0, h.len - 1));
  const at = h.viewing !== null ? h.phases[h.viewing] : null;
  $('timeline-label').textContent = at ? `viewing ${actionLabel(at)} (of ${h.len} phases)` : `live · ${h.len} phases`;
  $('go-live').disabled = h.viewing === null;
  document.body.classList.toggle('travelling', h.viewing !== null);
}

// PCA colours show the live decision only (the server keeps no embeddings of
// past phases): while viewing history the control is off, and says why.
function renderEmbeddingControl(s) {
  const past = !!(s.history && s.history.viewing !== null);
  const box = $('show-embedding');
  box.disabled = past;
  $('embedding-note').hidden = !past;
  $('embedding-opt').title = past
    ? 'embedding colours show the live decision only: press Live (or →) to see them'
    : 'the pair\'s policy\'s embeddings, live (at the match rotation) and demo, on their joint first three principal components';
}

// Demonstrate mode's status: what is being demonstrated, how the last action
// went (as far as the state tells), and what was saved. "saved to ..." stays
// until the next Demonstrate or Reset.
function renderDemoStatus(s) {
  const el = $('demo-status');
  const demo = s && s.demonstrate;
  el.classList.remove('bad', 'ok');
  if (!demo) {
    setText(el, app.saved ? `saved to ${app.saved}` : '');
    if (app.saved) el.classList.add('ok');
    el.hidden = !app.saved;
    return;
  }
  el.hidden = false;
  const n = demo.actions.length;
  // Progress after each number of actions (built-in tasks), to tell a place
  // that lowered it.
  app.demoProgress = (app.demoKey === `${demo.task}:${demo.seed}` && app.demoProgress) || [];
  app.demoKey = `${demo.task}:${demo.seed}`;
  app.demoProgress.length = n + 1;
  app.demoProgress[n] = demo.progress;
  const last = n ? demo.actions[n - 1] : null;
  let outcome = '';
  // A grasp that picked a block leaves it in the gripper: the state's
  // `holding` is the demonstration's world's.
  if (last && last.primitive === 'grasp' && s.holding === null) outcome = 'grasp missed: nothing was picked';
  else if (last && last.primitive === 'place' && demo.progress !== null && app.demoProgress[n - 1] != null
    && demo.progress < app.demoProgress[n - 1]) outcome = `place failed: progress fell from ${app.demoProgress[n - 1]} to ${demo.progress}`;
  const base = `${n} action${n === 1 ? '' : 's'}` + (demo.progress !== null ? ` · progress ${demo.progress} / 4` : '');
  if (outcome) { setText(el, `${outcome} · ${base} · undo, or ${s.primitive} again`); el.classList.add('bad'); }
  else setText(el, `${base} · next: ${s.primitive}, click the live heightmap`);
  el.title = `demonstrating ${demo.task} from seed ${demo.seed}: ${el.textContent}`;
  app.demoOutcome = outcome || null;
}

function travel(delta) {
  const h = app.state && app.state.history;
  if (!h || !h.len) return;
  const i = (h.viewing ?? h.len - 1) + delta;
  if (i >= h.len) send({ type: 'live' });
  else if (i >= 0) send({ type: 'goto', index: i });
}

async function requestFrame(force) {
  const s = app.state;
  if (!s) return;
  const pair = shownPair();
  const key = `${s.version}:${pair}`;
  if (!force && pending === key) return;
  pending = key;
  let f;
  try {
    const r = await fetch(`/api/frame?pair=${pair}`);
    f = await r.json();
  } catch (e) { showError(`cannot load the frame: ${e}`); return; }
  if (pending !== key) return; // a newer request superseded this one
  const n = f.resolution;
  images = {
    live: { color: rgbCanvas(b64bytes(f.live.color), n), depth: depthCanvas(b64f32(f.live.depth), n) },
    demo: f.demo ? { color: rgbCanvas(b64bytes(f.demo.color), n), depth: depthCanvas(b64f32(f.demo.depth), n) } : null,
    match: f.match_map ? heatCanvas(b64f32(f.match_map), n) : null,
    rematch: f.rematch_map ? heatCanvas(b64f32(f.rematch_map), n) : null,
    query: images.query, embedding: images.embedding,
  };
  app.frame = f;
  draw();
  requestEmbedding();
  app.frameVersion = f.version;
  document.body.dataset.frameVersion = String(f.version);
}

// What the pair's policy sees: its embeddings as PCA colours (live decisions only).
async function requestEmbedding() {
  const s = app.state, f = app.frame;
  if (!$('show-embedding').checked || !s || !f || !s.pairs.length || s.history.viewing !== null) {
    if (images.embedding) { images.embedding = null; draw(); }
    return;
  }
  if (images.embedding && images.embedding.version === f.version && images.embedding.pair === f.pair) return;
  let e;
  try {
    const r = await fetch(`/api/embedding?pair=${f.pair}`);
    if (!r.ok) { showError(await r.text()); return; }
    e = await r.json();
  } catch (err) { showError(`cannot load the embedding colours: ${err}`); return; }
  if (app.frame !== f) return; // superseded
  images.embedding = { version: f.version, pair: f.pair, live: rgbCanvas(b64bytes(e.live), e.resolution), demo: rgbCanvas(b64bytes(e.demo_rgb), e.resolution), policy: e.policy };
  app.embedding = e;
  draw();
}

function draw() {
  const s = app.state, f = app.frame;
  if (!s || !f) return;
  const n = f.resolution;
  const kind = $('show-depth').checked ? 'depth' : 'color';
  const op = Number($('opacity').value) / 100;
  const p = s.pairs[f.pair];
  const chosen = s.chosen === f.pair;

  // Demo side.
  const dm = [];
  // A pair without a demonstration (SPOT-Q's Q map, the TransporterNet's
  // scores) draws nothing on the demo side.
  if (p && f.demo) {
    dm.push({ kind: 'point', at: p.demo_action, color: '#ffffff', label: `demo ${act(p.demo_action)}`, ring: true });
    if (p.matched && p.rematch) dm.push({ kind: 'arrow', from: p.matched, to: p.rematch, color: '#ffaa00', label: `C = ${cValue(p)}` });
    if (p.rematch) dm.push({ kind: 'point', at: p.rematch, color: '#ffaa00' });
  }
  if (app.query) dm.push({ kind: 'point', at: app.query, color: '#ff4fd8', label: 'query', ring: true, below: true });
  const emb = images.embedding && images.embedding.pair === f.pair ? images.embedding : null;
  const labels = window.__seespotLabels = {};
  labels['demo-canvas'] = compose($('demo-canvas'), n, emb ? emb.demo : (images.demo ? images.demo[kind] : null), images.rematch ? images.rematch.canvas : null, op, dm);
  setText($('demo-title'), f.demo ? `Demo ${f.demo.demo} · step ${f.demo.step}${p ? ` · policy ${p.policy}` : ''}` : 'Demo (none)');

  // Live side.
  const lm = [];
  let heat = images.match;
  let label = images.match ? `match distance, ${p ? p.policy : ''} (r${p && p.matched ? p.matched.rotation : ''})` : 'no overlay';
  if (images.query) { heat = images.query; label = `query: demo pixel (${app.query.y}, ${app.query.x}) · ${app.queryPolicy}`; }
  if (p && p.matched) lm.push({ kind: 'arrow', from: p.demo_action, to: p.matched, color: chosen ? '#00e676' : '#ffffff', label: `L = ${fmt(p.l, 3)}` });
  if (p && p.matched) lm.push({ kind: 'point', at: p.matched, color: chosen ? '#00e676' : '#ffffff', label: chosen ? 'F (executed)' : 'F', ring: chosen });
  if ($('show-truth').checked && !s.demonstrate) {
    // The right actions' places; filled where the shown F's rotation takes
    // them as the oracle would (a cube repeats every quarter turn), outlined
    // otherwise.
    const info = app.info || {};
    const size = (info.block_size || 0.05) / ((info.workspace_size || 0.448) / n);
    const shownRotation = p && p.matched ? p.matched.rotation : null;
    for (const t of s.right_targets || []) {
      const d = shownRotation === null ? 0 : Math.abs(((shownRotation - t.rotation) % 4 + 4) % 4);
      lm.push({ kind: 'target', at: { y: t.pixel[0], x: t.pixel[1] }, yaw: t.yaw, size, filled: Math.min(d, 4 - d) <= 1,
        color: '#00e676', label: `right ${s.primitive} r${t.rotation}`, below: true });
    }
  }
  if (images.query && app.queryBest) lm.push({ kind: 'point', at: app.queryBest, color: '#ff4fd8', label: 'best', ring: true, below: true });
  const demo = s.demonstrate;
  if (demo) {
    heat = null; label = 'demonstrating: click to act';
    demo.actions.forEach((a, i) => lm.push({ kind: 'point', at: a, color: a.primitive === 'grasp' ? '#00e676' : '#ffaa00', label: i === demo.actions.length - 1 ? `${i + 1}: ${act(a)}` : null }));
    if (app.hover) {
      const info = app.info || {};
      const px = (info.workspace_size || 0.448) / n;
      lm.push({ kind: 'gripper', at: app.hover, yaw: (app.demoRotation * 2 * Math.PI) / ROTATIONS,
        jaw: (info.jaw_opening || 0.08) / px, finger: (info.block_size || 0.05) / px,
        color: s.primitive === 'grasp' ? '#00e676' : '#ffaa00', label: `${s.primitive} r${app.demoRotation}` });
    }
  }
  labels['live-canvas'] = compose($('live-canvas'), n, emb ? emb.live : images.live[kind], heat ? heat.canvas : null, op, lm);
  document.body.dataset.embedding = emb ? `${emb.policy}:${emb.version}` : '';
  setText($('overlay-label'), label);
  setText($('live-title'), demo ? `Demonstrating ${demo.task} from seed ${demo.seed}` : (s.phase === 'act' ? 'Live scene (before the action)' : 'Live scene'));
}

function onQuery(m) {
  const n = m.resolution;
  app.query = { y: m.y, x: m.x };
  app.queryPolicy = m.policy_name;
  app.queryBest = m.best ? { y: m.best.y, x: m.best.x } : null;
  app.lastQuery = m;
  images.query = heatCanvas(b64f32(m.map), n);
  $('query-result').textContent = m.best
    ? `Demo pixel (${m.y}, ${m.x}) under ${m.policy_name}: nearest live pixel (${m.best.y}, ${m.best.x}), distance ${m.best.distance.toFixed(3)}.`
    : 'No finite distance.';
  $('query-result').dataset.best = m.best ? `${m.best.y},${m.best.x}` : '';
  draw();
}

function clearQuery(redraw = true) {
  app.query = null; app.queryBest = null; images.query = null;
  $('query-result').textContent = 'Click the demo heightmap.';
  if (redraw) draw();
}

// Controls.
$('next-phase').onclick = () => send({ type: 'next_phase' });
$('next-action').onclick = () => send({ type: 'next_action' });
$('run').onclick = () => { app.running = true; send({ type: 'run' }); };
$('stop').onclick = () => { app.running = false; send({ type: 'stop' }); };
/** The seed box's value as a whole number, or null (and says so). */
function seedValue(what) {
  const raw = $('seed').value.trim();
  const v = Number(raw);
  if (raw === '' || !Number.isSafeInteger(v) || v < 0) {
    showError(`${what}: the seed must be a whole number, 0 or more${raw === '' ? '' : ` (not "${raw}")`}`);
    return null;
  }
  return v;
}
$('reset-form').onsubmit = (ev) => {
  ev.preventDefault();
  const seed = seedValue('Reset');
  if (seed === null) return;
  app.selectedPair = null; clearQuery(false);
  app.saved = null; renderDemoStatus(app.state);
  send({ type: 'reset', task: $('task').value, seed });
};
$('timeline').oninput = () => send({ type: 'goto', index: Number($('timeline').value) });
$('go-live').onclick = () => send({ type: 'live' });
$('show-depth').onchange = draw;
$('show-truth').onchange = draw;
// Labels keep 12 CSS pixels: redraw when the heightmaps change size.
let resizeTimer = null;
window.addEventListener('resize', () => { clearTimeout(resizeTimer); resizeTimer = setTimeout(draw, 100); });
$('show-embedding').onchange = () => { images.embedding = null; draw(); requestEmbedding(); };
$('opacity').oninput = draw;
$('clear-query').onclick = () => clearQuery();
$('demo-canvas').onclick = (ev) => {
  const s = app.state, f = app.frame;
  if (!s || !f || !f.demo) { showError('no demo shown yet: step to the embed phase'); return; }
  const { y, x } = pixelAt($('demo-canvas'), f.resolution, ev);
  send({ type: 'query', pair: f.pair, policy: Number($('query-policy').value || 0), y, x });
};
// Demonstrate mode: the live heightmap is the controller.
$('demo-start').onclick = () => {
  const task = $('demo-task').value.trim() || (app.state && app.state.task);
  const seed = seedValue('Demonstrate');
  if (seed === null) return;
  app.saved = null; renderDemoStatus(app.state);
  send({ type: 'demonstrate', task, seed, colours_matter: $('demo-colours').checked });
};
$('demo-undo').onclick = () => send({ type: 'demo_undo' });
$('demo-save').onclick = () => send({ type: 'demo_save', overwrite: $('demo-overwrite').checked });
$('demo-stop').onclick = () => { app.hover = null; send({ type: 'demo_stop' }); };
function turnGripper(delta) { app.demoRotation = (app.demoRotation + delta + ROTATIONS) % ROTATIONS; draw(); }
$('live-canvas').onclick = (ev) => {
  const s = app.state, f = app.frame;
  if (!s || !s.demonstrate || !f) return;
  const { y, x } = pixelAt($('live-canvas'), f.resolution, ev);
  send({ type: 'demo_act', action: { primitive: s.primitive, rotation: app.demoRotation, y, x } });
};
$('live-canvas').onmousemove = (ev) => {
  const s = app.state, f = app.frame;
  if (!s || !s.demonstrate || !f) return;
  app.hover = pixelAt($('live-canvas'), f.resolution, ev);
  draw();
};
$('live-canvas').onmouseleave = () => { if (app.hover) { app.hover = null; draw(); } };
$('live-canvas').addEventListener('wheel', (ev) => {
  if (!app.state || !app.state.demonstrate) return;
  ev.preventDefault();
  turnGripper(ev.deltaY > 0 ? 1 : -1);
}, { passive: false });
$('toggle-viewer').onclick = () => {
  const box = $('viewer-box');
  box.hidden = !box.hidden;
  if (!box.hidden && !$('viewer').src) $('viewer').src = app.info.viewer_url;
  $('toggle-viewer').textContent = box.hidden ? 'Show here' : 'Hide';
};
document.addEventListener('keydown', (ev) => {
  if (ev.target.closest('input, select')) return;
  if (ev.key === 'n') $('next-phase').click();
  else if (ev.key === 'a') $('next-action').click();
  else if (ev.key === 'r') $('run').click();
  else if (ev.key === 'ArrowLeft') travel(-1);
  else if (ev.key === 'ArrowRight') travel(1);
  else if (app.state && app.state.demonstrate && ev.key === '[') turnGripper(-1);
  else if (app.state && app.state.demonstrate && ev.key === ']') turnGripper(1);
  else if (app.state && app.state.demonstrate && ev.key === 'u') $('demo-undo').click();
});

connect();
