// The history: parts from /api/parts?view=summary with the form's filters.
'use strict';

const $ = (id) => document.getElementById(id);

function fmt(x, d) {
  return (x === null || x === undefined || !isFinite(x)) ? '—' : Number(x).toFixed(d);
}

async function load() {
  const form = new FormData($('filters'));
  const q = new URLSearchParams({ view: 'summary' });
  for (const [k, v] of form.entries()) if (v) q.set(k, v);
  const r = await fetch(`/api/parts?${q}`);
  const data = await r.json();
  const body = $('parts').tBodies[0];
  while (body.firstChild) body.removeChild(body.firstChild);
  if (!r.ok) {
    $('summary').textContent = data.error;
    return;
  }
  for (const p of data.slice().reverse()) {
    const tr = body.insertRow();
    const a = document.createElement('a');
    a.href = `/parts/${p.part}`;
    a.textContent = String(p.part);
    tr.insertCell().appendChild(a);
    const cells = [[p.serial, 'l'], [p.station, 'l'], [p.batch], [p.started_at.slice(0, 19).replace('T', ' '), 'l'], [fmt(p.initial_e_um, 1)], [fmt(p.final_e_um, 2)], [p.pushes], [fmt(p.time_s, 1)], [p.result, 'l ' + p.verdict], [p.reject_reason || '', 'l muted']];
    for (const [v, cls] of cells) {
      const td = tr.insertCell();
      td.textContent = String(v);
      if (cls) td.className = cls;
    }
  }
  const pass = data.filter((p) => p.verdict === 'pass').length;
  $('summary').textContent = `${data.length} part${data.length === 1 ? '' : 's'} shown: ${pass} pass, ${data.length - pass} reject`;
}

$('filters').addEventListener('submit', (e) => { e.preventDefault(); load().catch((err) => { $('summary').textContent = err.message; });
// New parts appear as the station stores them.
new EventSource('/api/events').addEventListener('stored', () => {
  load().catch((err) => { $('summary').textContent = err.message; });
}); });
load().catch((err) => { $('summary').textContent = err.message; });
// New parts appear as the station stores them.
new EventSource('/api/events').addEventListener('stored', () => {
  load().catch((err) => { $('summary').textContent = err.message; });
});
