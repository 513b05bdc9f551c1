// The live view: state from /api/live, then server-sent events from /api/events.
'use strict';

const SVGNS = 'http://www.w3.org/2000/svg';
const BLUE = '#0072B2', VERMILION = '#D55E00', GREEN = '#009E73', GREY = '#888';
const $ = (id) => document.getElementById(id);

const live = { serial: null, turn: -1, points: [], fitted: null, pushes: [], c: null, image: null, draws: 0 };

function el(tag, attrs, parent, text) {
  const e = document.createElementNS(SVGNS, tag);
  for (const k in attrs) e.setAttribute(k, attrs[k]);
  if (text !== undefined) e.textContent = text;
  if (parent) parent.appendChild(e);
  return e;
}

function fmt(x, d) {
  return (x === null || x === undefined || !isFinite(x)) ? '—' : Number(x).toFixed(d);
}

function clear(node) {
  while (node.firstChild) node.removeChild(node.firstChild);
}

function ticks(lo, hi, n) {
  const span = hi - lo || 1;
  const raw = span / n, mag = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => span / s <= n) || 10 * mag;
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + 1e-9; v += step) out.push(v);
  return { values: out, decimals: Math.max(0, -Math.floor(Math.log10(step))) };
}

// c(θ): the live trace of the turn in progress, then its stamped samples and the fit.
function drawCTheta() {
  const svg = $('ctheta');
  clear(svg);
  const W = 720, H = 340, L = 70, R = 14, T = 12, B = 44;
  const samples = live.fitted ? live.fitted.samples : live.points;
  const curve = live.fitted ? live.fitted.curve : [];
  const ys = samples.map((p) => p[1]).concat(curve.map((p) => p[1]));
  let y0 = Math.min(...ys), y1 = Math.max(...ys);
  if (!ys.length) { y0 = 700; y1 = 740; }
  const pad = (y1 - y0) * 0.08 || 1;
  y0 -= pad; y1 += pad;
  const x = (v) => L + (W - L - R) * v / 360;
  const y = (v) => T + (H - T - B) * (1 - (v - y0) / (y1 - y0));
  el('rect', { x: L, y: T, width: W - L - R, height: H - T - B, fill: '#fff', stroke: '#ccc' }, svg);
  for (const v of [0, 60, 120, 180, 240, 300, 360]) {
    el('line', { x1: x(v), x2: x(v), y1: T, y2: H - B, stroke: '#eee' }, svg);
    el('text', { x: x(v), y: H - B + 16, 'text-anchor': 'middle', 'font-size': 12 }, svg, String(v));
  }
  const yt = ticks(y0, y1, 6);
  for (const v of yt.values) {
    el('line', { x1: L, x2: W - R, y1: y(v), y2: y(v), stroke: '#eee' }, svg);
    el('text', { x: L - 6, y: y(v) + 4, 'text-anchor': 'end', 'font-size': 12 }, svg, v.toFixed(yt.decimals));
  }
  el('text', { x: (L + W - R) / 2, y: H - 6, 'text-anchor': 'middle', 'font-size': 13 }, svg, 'angle turned since the first frame / °');
  el('text', { x: 16, y: (T + H - B) / 2, 'text-anchor': 'middle', 'font-size': 13, transform: `rotate(-90 16 ${(T + H - B) / 2})` }, svg, 'ring column c / px');
  const g = el('g', {}, svg);
  for (const p of samples) {
    el('circle', { cx: x(p[0]).toFixed(1), cy: y(p[1]).toFixed(1), r: 2.2, fill: BLUE, 'fill-opacity': 0.65 }, g);
  }
  if (curve.length) {
    el('polyline', { points: curve.map((p) => `${x(p[0]).toFixed(1)},${y(p[1]).toFixed(1)}`).join(' '), fill: 'none', stroke: VERMILION, 'stroke-width': 1.6 }, svg);
  }
  svg.dataset.points = String(samples.length);
  svg.dataset.draws = String(++live.draws);
  svg.dataset.fitted = curve.length ? '1' : '0';
  const note = live.fitted
    ? (live.fitted.previous ? `${live.fitted.previous}, last turn: ` : '') + `turn ${live.fitted.turn + 1} (${live.fitted.kind}): e = ${fmt(live.fitted.e_um, 2)} µm at ${fmt(live.fitted.theta_max_deg, 1)}°, ${live.fitted.valid_frames} of ${live.fitted.frames_taken} frames` +
      (live.fitted.trusted === false ? ' — failed the quality gate' : live.fitted.trusted === null ? ' — ring lost' : '')
    : (live.turn >= 0 ? `turn ${live.turn + 1}: ${samples.length} frames so far` : '');
  $('turn-note').textContent = note;
}

// The frame: the image (full fidelity) or a schematic of the window with the ring's edges.
function drawThumb() {
  const svg = $('thumb');
  clear(svg);
  const W = 360, H = 135, s = W / 1440;
  const zoom = $('zoom');
  clear(zoom);
  if (live.image) {
    const im = live.image;
    el('image', { href: im.src, x: 0, y: 0, width: W, height: H, preserveAspectRatio: 'none' }, svg);
    for (const c of im.edges_px) {
      el('line', { x1: c * W / im.width, x2: c * W / im.width, y1: 0, y2: H, stroke: VERMILION, 'stroke-width': 1, 'stroke-opacity': 0.9 }, svg);
    }
    if (im.zoom_src) {
      // The strip around the ring, one screen unit per frame column.
      const zs = W / im.zoom_width_px;
      el('rect', { x: im.zoom_x0_px * W / im.width, y: 0, width: im.zoom_width_px * W / im.width, height: H, fill: 'none', stroke: '#fff', 'stroke-dasharray': '3 2' }, svg);
      el('image', { href: im.zoom_src, x: 0, y: 0, width: W, height: H, preserveAspectRatio: 'none' }, zoom);
      for (const c of im.edges_px) {
        const x = (c - im.zoom_x0_px) * zs;
        if (x >= 0 && x <= W) el('line', { x1: x, x2: x, y1: 0, y2: H, stroke: VERMILION, 'stroke-width': 1.2 }, zoom);
      }
      zoom.style.display = 'block';
    } else {
      zoom.style.display = 'none';
    }
    $('frame-note').textContent = 'rendered frame; below, the columns around the ring at full resolution; detected edges in red';
    return;
  }
  zoom.style.display = 'none';
  el('rect', { x: 0, y: 0, width: W, height: H, fill: '#2b2b2b' }, svg);
  for (let k = 0; k < 40; k++) {
    el('line', { x1: k * 9, x2: k * 9, y1: 0, y2: H, stroke: '#3a3a3a', 'stroke-width': 3 }, svg);
  }
  if (live.c !== null && live.c !== undefined) {
    const cx = live.c * s, half = 5.3 * s;
    el('rect', { x: cx - half, y: 0, width: 2 * half, height: H, fill: '#e8e8e8' }, svg);
    el('line', { x1: cx - half, x2: cx - half, y1: 0, y2: H, stroke: VERMILION, 'stroke-width': 1.5 }, svg);
    el('line', { x1: cx + half, x2: cx + half, y1: 0, y2: H, stroke: VERMILION, 'stroke-width': 1.5 }, svg);
    $('frame-note').textContent = `ring at c = ${fmt(live.c, 2)} px (schematic: the fast simulation renders no image)`;
  } else {
    el('text', { x: W / 2, y: H / 2, fill: '#ddd', 'text-anchor': 'middle', 'font-size': 13 }, svg, 'no ring in this frame');
    $('frame-note').textContent = '';
  }
}

function drawPushes() {
  const body = $('pushes').tBodies[0];
  clear(body);
  live.pushes.forEach((p, i) => {
    const tr = body.insertRow();
    for (const v of [i + 1, fmt(p.e_before_um, 2), fmt(p.commanded_um, 2), fmt(p.angle_deg, 1), p.approach, fmt(p.predicted_e_after_um, 2)]) {
      tr.insertCell().textContent = String(v);
    }
  });
  // Each push as an arrow from the eccentricity it started from toward the centre.
  const svg = $('pushplot');
  clear(svg);
  const cx = 180, cy = 100, R = 88;
  el('circle', { cx, cy, r: R, fill: '#fff', stroke: '#ccc' }, svg);
  el('line', { x1: cx - R, x2: cx + R, y1: cy, y2: cy, stroke: '#eee' }, svg);
  el('line', { x1: cx, x2: cx, y1: cy - R, y2: cy + R, stroke: '#eee' }, svg);
  el('circle', { cx, cy, r: 2.5, fill: GREY }, svg);
  const emax = Math.max(1, ...live.pushes.map((p) => p.e_before_um || 0));
  el('text', { x: cx + R + 4, y: cy + 4, 'font-size': 11 }, svg, `${fmt(emax, 0)} µm`);
  const colours = [BLUE, VERMILION, GREEN, '#E69F00', '#CC79A7'];
  live.pushes.forEach((p, i) => {
    const a = (p.angle_deg || 0) * Math.PI / 180, r = R * (p.e_before_um || 0) / emax;
    const x0 = cx + r * Math.cos(a), y0 = cy - r * Math.sin(a);
    const c = colours[i % colours.length];
    el('line', { x1: x0, y1: y0, x2: cx, y2: cy, stroke: c, 'stroke-width': 2 }, svg);
    el('circle', { cx: x0, cy: y0, r: 4, fill: c }, svg);
    el('text', { x: x0 + 6, y: y0 - 4, 'font-size': 11, fill: c }, svg, String(i + 1));
  });
}

// The last finished part's time by phase (the finished event's phase_times).
function drawTimes(t) {
  const body = $('times').tBodies[0];
  clear(body);
  if (!t) return;
  $('times-note').textContent = `of ${t.serial}: ${fmt(t.time_s, 1)} s, ${t.pushes} push${t.pushes === 1 ? '' : 'es'}`;
  const focus = t.focus_checks > 0 && t.focus_sweeps === 0 ? 'carried focus checked'
    : `${t.focus_sweeps} sweep${t.focus_sweeps === 1 ? '' : 's'}${t.focus_checks ? ` after ${t.focus_checks} check${t.focus_checks === 1 ? '' : 's'}` : ''}`;
  const rows = [
    ['focus', t.focus_s, focus],
    ['measure', t.measure_s, `${t.turns} turn${t.turns === 1 ? '' : 's'}`],
    ['push', t.push_s, ''],
    ['\u2003align', t.align_s, 'with the servo\u2019s brake'],
    ['\u2003approach', t.approach_s, ''],
    ['\u2003stroke', t.stroke_s, ''],
    ['\u2003retract', t.retract_s, ''],
  ];
  for (const [name, v, note] of rows) {
    const tr = body.insertRow();
    [[name, 'l'], [fmt(v, 2), ''], [note, 'l muted small']].forEach(([x, cls]) => {
      const td = tr.insertCell();
      td.textContent = String(x);
      if (cls) td.className = cls;
    });
  }
}

function setPhase(p) {
  $('phase').textContent = p;
}

async function getJSON(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: ${r.status}`);
  return r.json();
}

async function refreshCounters() {
  const s = await getJSON('/api/stats');
  const st = s.store, pa = s.paper;
  const rows = [
    ['parts', st.parts, pa.parts],
    ['pass / reject', `${st.pass} / ${st.reject}`, '—'],
    ['mean time / s', fmt(st.mean_time_s, 1), fmt(pa.mean_time_s, 1)],
    ['mean pushes (max)', st.mean_pushes === null ? '—' : `${fmt(st.mean_pushes, 2)} (${st.max_pushes})`, `${fmt(pa.mean_pushes, 1)} (${pa.max_pushes})`],
    ['mean final e / µm', fmt(st.mean_final_e_um, 2), fmt(pa.mean_final_e_um, 1)],
  ];
  const body = $('counters').tBodies[0];
  clear(body);
  for (const r of rows) {
    const tr = body.insertRow();
    r.forEach((v, i) => { const td = tr.insertCell(); td.textContent = String(v); if (i === 0) td.className = 'l'; });
  }
  $('paper-head').textContent = pa.source;
}

async function refreshRecent() {
  const parts = await getJSON('/api/parts?view=summary&limit=10');
  const body = $('recent').tBodies[0];
  clear(body);
  for (const p of parts.reverse()) {
    const tr = body.insertRow();
    const a = document.createElement('a');
    a.href = `/parts/${p.part}`;
    a.textContent = String(p.part);
    tr.insertCell().appendChild(a);
    const cells = [[p.serial, 'l'], [p.started_at.slice(0, 19).replace('T', ' '), 'l'], [fmt(p.initial_e_um, 1)], [fmt(p.final_e_um, 2)], [p.pushes], [fmt(p.time_s, 1)], [p.result, 'l ' + p.verdict]];
    for (const [v, cls] of cells) {
      const td = tr.insertCell();
      td.textContent = String(v);
      if (cls) td.className = cls;
    }
  }
}

async function refreshTiming() {
  const s = await getJSON('/api/status');
  const t = s.frame_timing;
  const l = s.plc;
  $('timing').textContent = (t && t.frames)
    ? `frame loop: ${t.frames} frames, lateness p50 ${fmt(t.p50_late_ms, 2)} ms, p99 ${fmt(t.p99_late_ms, 2)} ms, max ${fmt(t.max_late_ms, 1)} ms; ${t.late_frames} frames later than one period (${fmt(t.period_ms, 1)} ms)`
    : (l && l.requests)
      ? `PLC link ${l.address}: ${l.requests} requests, round trip p50 ${fmt(l.round_trip_p50_ms, 2)} ms, p99 ${fmt(l.round_trip_p99_ms, 2)} ms; ${l.frames_paired} frames paired with a latched angle, ${l.frames_stale} stale`
      : (s.station ? '' : 'no station attached: history and counters only');
}

function loadState(st) {
  live.serial = st.serial;
  live.turn = st.turn;
  live.points = st.points || [];
  live.fitted = st.last_turn && st.last_turn.turn === st.turn ? st.last_turn : null;
  live.pushes = st.pushes || [];
  live.c = st.c_px;
  live.image = st.image;
  $('serial').textContent = st.serial || '—';
  setPhase(st.phase);
  drawTimes(st.last_phase_times);
  drawCTheta();
  drawThumb();
  drawPushes();
}

function report(e) {
  $('conn').textContent = `error: ${e.message}`;
}

const handlers = {
  part(d) {
    // The last fitted turn stays on the plot, marked as the previous part's, until the new
    // part's first frames arrive.
    if (live.fitted) live.fitted.previous = live.serial;
    live.serial = d.serial; live.turn = -1; live.points = []; live.pushes = [];
    $('serial').textContent = d.serial;
    drawCTheta(); drawPushes();
  },
  phase(d) { setPhase(d.phase); },
  frames(d) {
    if (d.turn !== live.turn) { live.turn = d.turn; live.points = []; live.fitted = null; }
    live.points.push(...d.points);
    live.c = d.c_px;
    drawCTheta(); if (!live.image) drawThumb();
  },
  turn(d) { live.fitted = d; live.turn = d.turn; drawCTheta(); },
  push(d) { live.pushes.push(d); drawPushes(); },
  image(d) { live.image = d; drawThumb(); },
  finished(d) { setPhase('idle'); drawTimes(d.phase_times); },
  stored() { refreshCounters().catch(report); refreshRecent().catch(report); refreshTiming().catch(report); },
  batch(d) { setPhase('idle'); $('conn').textContent = d.message; },
  resync() { getJSON('/api/live').then(loadState).catch(report); },
};

function connect() {
  const es = new EventSource('/api/events');
  es.onopen = () => { $('conn').textContent = 'live'; };
  es.onerror = () => { $('conn').textContent = 'reconnecting…'; };
  for (const name in handlers) {
    es.addEventListener(name, (ev) => {
      try { handlers[name](JSON.parse(ev.data)); } catch (e) { report(e); }
    });
  }
}

getJSON('/api/live').then(loadState).catch(report);
refreshCounters().catch(report);
refreshRecent().catch(report);
refreshTiming().catch(report);
connect();
setInterval(() => { refreshTiming().catch(report); }, 2000);
