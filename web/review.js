// The review page: every trial of the evaluation the server was started on
// (`seespot view --review DIR`), its outcome and failure kind, counts per
// method and fold, and one click to replay a trial in the debugger.
const $ = (id) => document.getElementById(id);
const SHOWN = 300; // rows listed at once

// Exposed for the browser tests.
const review = window.seespotReview = { data: null, filter: null, errors: [], replaying: null };

function showError(msg) {
  review.errors.push(msg);
  const e = $('error');
  e.textContent = msg; e.hidden = false;
}

function cell(tr, text, cls) {
  const td = document.createElement('td');
  td.textContent = text;
  if (cls) td.className = cls;
  tr.appendChild(td);
  return td;
}

function pct(k, n) { return n ? `${Math.round((100 * k) / n)}%` : '–'; }

function drawCounts(d) {
  const head = document.createElement('tr');
  const labelled = d.counts.some((c) => c.truth);
  for (const h of ['method', 'reads', 'fold', 'trials', 'success', ...d.kinds.map((k) => k.label), ...(labelled ? ['matches right'] : []), 'replay']) {
    const th = document.createElement('th'); th.textContent = h; head.appendChild(th);
    if (h === 'matches right') th.title = 'labelled records (seespot eval --truth): the share of every pair\'s F that the simulator judges right; the tooltip gives the actions right and where failed trials first went wrong';
  }
  $('counts-head').replaceChildren(head);
  const rows = d.counts.map((c) => {
    const tr = document.createElement('tr');
    tr.dataset.method = c.method; tr.dataset.task = c.task;
    cell(tr, c.method);
    const reads = cell(tr, c.reads || '');
    reads.dataset.testid = 'reads';
    if (c.reads === 'simulator') reads.title = 'reads the simulator\'s state: a privileged upper reference';
    cell(tr, c.task); cell(tr, String(c.trials));
    cell(tr, `${c.successes} (${pct(c.successes, c.trials)})`);
    for (const k of d.kinds) {
      const n = c.failures[k.key] || 0;
      const td = cell(tr, String(n), n ? 'count' : 'zero');
      td.dataset.kind = k.key;
      if (n) td.onclick = () => setFilter({ method: c.method, task: c.task, kind: k.key, label: k.label });
    }
    if (labelled) {
      const t = c.truth;
      const td = cell(tr, t ? pct(t.matches_right, t.matches) : '–');
      td.dataset.testid = 'matches-right';
      if (t) {
        const first = Object.entries(t.first_wrong).map(([k, [g, p]]) => `${k}: ${g} at a grasp, ${p} at a place`);
        td.title = [`${t.matches_right} of ${t.matches} matches right over ${t.trials} labelled trials`,
          `${t.right} of ${t.decisions} actions right`, ...(first.length ? ['failed trials, first wrong step:', ...first] : [])].join('\n');
      }
    }
    // A short word; the reason on hover.
    cell(tr, c.replay.ok ? 'yes' : 'no', c.replay.ok ? 'ok' : 'refused').title = c.replay.ok
      ? 'the records were made with today\'s models and demonstrations'
      : c.replay.reason;
    return tr;
  });
  $('counts-body').replaceChildren(...rows);
}

function setFilter(f) {
  review.filter = f;
  $('filter-label').textContent = f ? `${f.method} · ${f.task} · ${f.label}` : 'every failure, by kind';
  drawTrials();
}

function replayable(t) {
  const c = review.data.counts.find((x) => x.method === t.method && x.task === t.task);
  return c ? c.replay : { ok: false, reason: 'no such records' };
}

function drawTrials() {
  const d = review.data;
  const order = new Map(d.kinds.map((k, i) => [k.key, i]));
  const method = $('method-filter').value;
  const f = review.filter;
  const list = d.trials
    .filter((t) => $('show-successes').checked || !t.success)
    .filter((t) => !method || t.method === method)
    .filter((t) => !f || (t.method === f.method && t.task === f.task && t.failure === f.kind))
    .sort((a, b) => (order.get(a.failure) ?? -1) - (order.get(b.failure) ?? -1)
      || a.method.localeCompare(b.method) || a.task.localeCompare(b.task) || a.seed - b.seed);
  const kindLabel = new Map(d.kinds.map((k) => [k.key, k.label]));
  const rows = list.slice(0, SHOWN).map((t) => {
    const tr = document.createElement('tr');
    tr.dataset.testid = 'trial';
    cell(tr, t.method); cell(tr, t.task); cell(tr, String(t.seed));
    cell(tr, t.success ? 'success' : kindLabel.get(t.failure) || 'failed', t.success ? 'ok' : 'refused');
    cell(tr, String(t.actions)); cell(tr, `${t.max_progress} / 4`);
    const dep = cell(tr, t.departures.length ? String(t.departures.length) : '');
    dep.dataset.testid = 'departures';
    if (t.departures.length) dep.title = t.departures.join('\n');
    const w = t.truth && t.truth.first_wrong;
    const first = cell(tr, w ? `${w.action}: ${w.label}` : (t.truth ? '' : '–'));
    first.dataset.testid = 'first-wrong';
    if (w) first.title = `action ${w.action} (${w.primitive}): ${w.why}`;
    const td = cell(tr, '');
    const r = replayable(t);
    const b = document.createElement('button');
    b.textContent = 'Replay'; b.dataset.testid = 'replay';
    b.disabled = !r.ok; b.title = r.ok ? 'open this trial in the debugger' : r.reason;
    b.onclick = () => replay(t);
    const a = document.createElement('a');
    a.textContent = '.rrd'; a.className = 'button'; a.dataset.testid = 'rrd';
    if (r.ok && review.data.recordings) {
      const q = new URLSearchParams({ method: t.method, task: t.task, seed: String(t.seed) });
      a.href = `/api/replay.rrd?${q}`;
      a.download = `${t.method}-${t.task.replace(":", "-")}-${t.seed}.rrd`;
    } else a.hidden = true;
    td.append(b, ' ', a);
    return tr;
  });
  $('trials-body').replaceChildren(...rows);
  $('more').textContent = list.length > SHOWN ? `${list.length - SHOWN} more not listed: narrow the filter` : `${list.length} trials`;
}

// Asks the server to load the trial into the debugger, then opens it.
function replay(t) {
  review.replaying = t;
  const ws = new WebSocket(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`);
  ws.onopen = () => ws.send(JSON.stringify({ type: 'replay', method: t.method, task: t.task, seed: t.seed }));
  ws.onmessage = (ev) => {
    let m;
    try { m = JSON.parse(ev.data); } catch { return; }
    if (m.type === 'replay') { ws.close(); location.href = '/'; }
    // A finetuned run's first replay finetunes its models first (minutes).
    else if (m.type === 'busy' && m.what) {
      review.busy = m;
      $('conn').textContent = `preparing ${m.what}: ${m.seconds} s`;
      $('conn').title = m.why || '';
    }
    else if (m.type === 'error' && m.request === 'replay') { ws.close(); showError(m.message); }
  };
  ws.onerror = () => showError('cannot reach the seespot server');
}

function act(a) { return a ? `${a.primitive} r${a.rotation} (${a.y}, ${a.x})` : 'nothing (ended)'; }

// The discordant seeds of the two chosen runs, sorted by where they part;
// a click opens the difference view.
async function drawDiscordant() {
  const a = $('run-a').value, b = $('run-b').value;
  review.discordant = null;
  if (!a || !b || a === b) {
    $('discordant-summary').textContent = 'choose two different runs';
    $('discordant-body').replaceChildren();
    return;
  }
  $('discordant-summary').textContent = 'reading the records…';
  const r = await fetch(`/api/divergences?${new URLSearchParams({ a, b })}`);
  if (!r.ok) { showError(await r.text()); return; }
  const list = await r.json();
  if ($('run-a').value !== a || $('run-b').value !== b) return; // superseded
  review.discordant = { a, b, list };
  const onlyA = list.filter((d) => d.first_succeeded).length;
  $('discordant-summary').textContent = `${list.length} discordant seeds: ${onlyA} where only ${a} succeeded, ${list.length - onlyA} where only ${b} did.`;
  const rows = list.slice(0, SHOWN).map((d) => {
    const tr = document.createElement('tr');
    tr.className = 'discordant'; tr.dataset.testid = 'discordant-seed';
    cell(tr, d.task); cell(tr, String(d.seed));
    cell(tr, d.first_succeeded ? `only ${a}` : `only ${b}`, 'ok');
    cell(tr, String(d.action_index + 1)); cell(tr, `${d.progress_before} / 4`);
    cell(tr, act(d.first && d.first.action)); cell(tr, act(d.second && d.second.action));
    const q = new URLSearchParams({ a, b, task: d.task, seed: String(d.seed) });
    tr.title = 'both trials side by side from this action';
    tr.onclick = () => { location.href = `/difference?${q}`; };
    return tr;
  });
  $('discordant-body').replaceChildren(...rows);
}

// The two run boxes: the reviewed evaluation's runs, then those of the
// evaluations given beside it (`seespot view --compare DIR`, named N:RUN).
async function fillRuns() {
  const r = await fetch('/api/runs');
  if (!r.ok) { showError(await r.text()); return; }
  const folders = await r.json();
  review.folders = folders;
  const runs = folders.flatMap((f) => f.runs.map((run) => ({ run, label: f.folder ? `${run} (${f.dir})` : run })));
  for (const [id, want] of [['run-a', 'ssr-ccd'], ['run-b', 'ssr-l2cd']]) {
    const sel = $(id);
    for (const { run, label } of runs) sel.add(new Option(label, run));
    const names = runs.map((x) => x.run);
    sel.value = names.includes(want) ? want : names[id === 'run-a' ? 0 : Math.min(1, names.length - 1)] || '';
    sel.onchange = () => drawDiscordant().catch((e) => showError(String(e)));
  }
}

async function load() {
  const r = await fetch('/api/review');
  if (!r.ok) { showError(await r.text()); $('conn').textContent = 'no evaluation'; return; }
  const d = await r.json();
  review.data = d;
  $('conn').textContent = `${d.trials.length} trials`; $('conn').className = 'conn ok';
  $('source').textContent = `${d.dir}: ${d.trials.length} trials in ${d.counts.length} records files`;
  const sel = $('method-filter');
  for (const m of [...new Set(d.counts.map((c) => c.method))]) sel.add(new Option(m, m));
  sel.onchange = () => { review.filter = null; setFilter(null); };
  $('show-successes').onchange = drawTrials;
  drawCounts(d);
  drawTrials();
  await fillRuns();
  await drawDiscordant();
}

load().catch((e) => showError(String(e)));
