// volux viewer — the page of `volux serve` (served from the binary).
//
// Every control turns into edits in the --set form, [{"path", "value"}],
// POSTed to /api/edit; the server applies them to the live scene (the
// technique then does its incremental update) and pushes frames on the
// event stream /api/events: a preview right after an edit, refinement
// frames, and the final frame (what `volux render` writes). At most one
// edit is in flight; edits made meanwhile are merged by path, so dragging
// sends the latest state as fast as the server answers.
'use strict';

const $ = (id) => document.getElementById(id);
const token = new URLSearchParams(location.search).get('token');
const auth = token ? { 'X-Volux-Token': token } : {};

let state = null;        // /api/state
let techniques = [];     // /api/techniques
let dragging = 0;        // controls being dragged: server state must not overwrite them
const pending = new Map();
let inflight = false;
const editT0 = [];       // [version, t0] of edits whose frame has not been seen
const latencies = [];    // edit → first frame on screen, ms (page-measured)
// window.volux: what tests and benchmarks read (and `edit`, the controls'
// own path to the server, so a script's edit is timed like a drag).
window.volux = { latencies, frames: [], lastFrame: null, state: () => state, errors: [] };

async function api(path, opts = {}) {
  const r = await fetch(path, { ...opts, headers: { ...auth, ...(opts.headers || {}) } });
  return r;
}

function showError(msg) {
  const e = $('error');
  e.textContent = msg;
  e.hidden = !msg;
  if (msg) window.volux.errors.push(msg);
  clearTimeout(showError.timer);
  if (msg) showError.timer = setTimeout(() => { e.hidden = true; }, 8000);
}

// ---------------------------------------------------------------- edits

function edit(list) {
  for (const { path, value } of list) {
    // A later value of a path (or of an ancestor) replaces queued edits
    // under it; re-inserting keeps the order of application.
    for (const p of [...pending.keys()])
      if (p === path || p.startsWith(path + '.')) pending.delete(p);
    pending.set(path, value);
  }
  if (!edit.t0) edit.t0 = performance.now();
  pump();
}

async function pump() {
  if (inflight || pending.size === 0) return;
  const list = [...pending].map(([path, value]) => ({ path, value }));
  pending.clear();
  const t0 = edit.t0;
  edit.t0 = 0;
  inflight = true;
  try {
    const r = await api('/api/edit', {
      method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(list),
    });
    const j = await r.json();
    if (!r.ok) {
      showError(j.error || r.statusText);
      await loadState(); // the controls go back to what the scene holds
    } else {
      editT0.push([j.version, t0]);
      showError('');
    }
  } catch (e) {
    showError('edit failed: ' + e);
  }
  inflight = false;
  pump();
}

// ---------------------------------------------------------------- frames

function connect() {
  const es = new EventSource('/api/events' + (token ? '?token=' + encodeURIComponent(token) : ''));
  es.addEventListener('frame', async (ev) => {
    const f = JSON.parse(ev.data);
    const img = new Image();
    img.src = 'data:image/' + f.format + ';base64,' + f.data;
    try { await img.decode(); } catch (e) { return; }
    const frame = $('frame');
    frame.src = img.src;
    const now = performance.now();
    // The first frame that shows an edit closes its latency.
    while (editT0.length && editT0[0][0] <= f.version) {
      const [, t0] = editT0.shift();
      latencies.push(now - t0);
      $('st-latency').textContent = `edit → frame ${(now - t0).toFixed(0)} ms (median ${median(latencies).toFixed(0)})`;
    }
    delete f.data;
    f.shown = now;
    window.volux.lastFrame = f;
    window.volux.frames.push(f);
    if (window.volux.frames.length > 200) window.volux.frames.shift();
    // a first frame may march at a coarser step than render.step (--preview-step)
    const coarse = f.step_scale > 1 ? `, step ×${f.step_scale}` : '';
    // a stand-in: a cheaper technique's frame of the new state while the scene's own one prepares
    const standIn = f.stand_in ? `stand-in (${f.stand_in}) · ` : '';
    const r = state && state.resolved ? state.resolved.render : null;
    const limits = r && r.spp > 1 ? ` of ${r.spp}${r.target_error > 0 ? `, to ${r.target_error * 100}% error` : ''}${
      r.time_ms > 0 ? `, ≤ ${r.time_ms / 1000} s` : ''}` : '';
    $('st-kind').textContent = `${standIn}${f.kind} ${f.width}×${f.height}${coarse}, ${f.spp} spp${limits}, frame ${f.id}`;
    $('st-server').textContent = `render ${f.render_ms.toFixed(0)} ms, encode ${f.encode_ms.toFixed(1)} ms (${f.format}, ${(f.bytes / 1024).toFixed(0)} KiB)`;
  });
  es.addEventListener('scene', (ev) => {
    const v = JSON.parse(ev.data).version;
    if (!state || v !== state.version) loadState();
  });
  es.addEventListener('failure', (ev) => showError(JSON.parse(ev.data).error));
  // preparation in progress ("preparing single: 40 %"); task "" when done
  es.addEventListener('busy', (ev) => {
    const b = JSON.parse(ev.data);
    window.volux.busy = b;
    (window.volux.busyLog ||= []).push(b);
    if (window.volux.busyLog.length > 100) window.volux.busyLog.shift();
    const el = $('st-busy');
    el.hidden = !b.task;
    el.textContent = b.task ? `${b.task}: ${b.percent} %` : '';
  });
  es.onerror = () => { $('st-kind').textContent = 'reconnecting…'; };
}

function median(a) {
  const s = [...a].sort((x, y) => x - y);
  return s.length ? s[Math.floor((s.length - 1) / 2)] : 0;
}

// ---------------------------------------------------------------- state

async function loadState() {
  const r = await api('/api/state');
  if (!r.ok) { showError('cannot read the scene: ' + r.status); return; }
  const s = await r.json();
  if (state && s.version < state.version) return;
  state = s;
  window.volux.version = s.version;
  if (!dragging) refresh();
}

function sceneTF() { return state.scene.transfer_function; }
function resolvedTF() { return state.resolved.transfer_function; }
function tfKey() { return resolvedTF().extinction ? 'extinction' : 'opacity'; }

// Edits of the TF: by path when the scene holds an inline TF without a
// preset; otherwise the whole TF object (a file name or a preset cannot be
// edited point by point), rebuilt from what the scene resolved.
function tfEdit(changes) {
  const tf = sceneTF();
  if (tf && typeof tf === 'object' && !('preset' in tf)) {
    edit(Object.entries(changes).map(([k, v]) => ({ path: 'transfer_function.' + k, value: v })));
    return;
  }
  const r = resolvedTF();
  const obj = typeof tf === 'object' ? { ...tf } : {};
  delete obj.preset; delete obj.preset_name; delete obj.preset_rescale;
  obj.color = r.color;
  obj[tfKey()] = r[tfKey()];
  for (const k of ['albedo', 'anisotropy', 'density_scale']) obj[k] = r[k];
  if (!r.extinction && r.opacity_unit_distance > 0) obj.opacity_unit_distance = r.opacity_unit_distance;
  Object.assign(obj, changes);
  edit([{ path: 'transfer_function', value: obj }]);
  // the resolved copy follows at once, so the next drag step sees it
  Object.assign(r, changes);
}

function refresh() {
  $('scene-name').textContent = state.scene_path;
  refreshTechnique();
  refreshMaterial();
  drawTF();
  refreshLights();
  refreshRender();
  refreshClip();
  cam.fromState();
  refreshView();
  refreshSlices();
}

// ---------------------------------------------------------------- technique

// Which technique when, in one line each (measured: docs/CHOOSING.md).
const TECHNIQUE_HINTS = {
  ea: 'when: structure at a glance, every edit instant; no lighting at all',
  shaded: 'when: instant surface-like shading; no shadows, no scattering',
  pathtrace: 'when: one image or frequent TF edits; the truth, noise falls with time (no preparation)',
  single: 'when: orbiting a fixed scene with crisp one-bounce shadows; seconds to prepare',
  ao: 'when: a cheap soft-shadow look; occlusion only, darker than the truth',
  ambient: 'when: orbiting with a multiple-scattering look; fast to prepare, approximate brightness',
  lightvol: 'when: orbiting or editing lights; the best per-frame speed-up measured',
  sh: 'when: many light/camera edits on a fixed TF; seconds to prepare',
  manylights: 'when: a noise-free multiple-scattering still; slowest to prepare',
  guided: 'when: HDR-lit scenes over many passes; with only a key light it is pathtrace',
};

function refreshTechnique() {
  const sel = $('technique');
  if (!sel.options.length)
    for (const t of techniques) {
      const o = new Option(t.name, t.name);
      if (TECHNIQUE_HINTS[t.name]) o.title = TECHNIQUE_HINTS[t.name];
      sel.add(o);
    }
  const name = state.resolved.render.technique;
  sel.value = name;
  const info = techniques.find((t) => t.name === name);
  const hint = TECHNIQUE_HINTS[name];
  $('technique-summary').textContent =
    (info ? info.summary : '') + (hint ? ` — ${hint} (docs/CHOOSING.md)` : '');
  const box = $('params');
  box.replaceChildren();
  if (!info) return;
  const given = (state.scene.techniques || {})[name] || {};
  // One control per entry of the technique's parameter table.
  for (const p of info.params) {
    const label = document.createElement('label');
    label.title = p.doc;
    const span = document.createElement('span');
    span.textContent = p.name;
    label.append(span);
    const value = p.name in given ? given[p.name] : p.default;
    let input;
    if (p.kind === 'bool') {
      input = document.createElement('input');
      input.type = 'checkbox';
      input.checked = !!value;
      input.onchange = () => edit([{ path: `techniques.${name}.${p.name}`, value: input.checked }]);
    } else if (p.kind === 'string' || p.kind === 'file') {
      input = document.createElement('input');
      input.type = 'text';
      input.value = value;
      input.onchange = () => edit([{ path: `techniques.${name}.${p.name}`, value: input.value }]);
    } else {
      input = document.createElement('input');
      input.type = 'number';
      input.min = p.min; input.max = p.max;
      input.step = p.kind === 'int' ? 1 : 'any';
      input.value = value;
      input.onchange = () => {
        const v = Number(input.value);
        if (input.value !== '' && Number.isFinite(v)) edit([{ path: `techniques.${name}.${p.name}`, value: v }]);
      };
    }
    input.dataset.param = p.name;
    label.append(input);
    if (p.name in given) {
      const reset = document.createElement('button');
      reset.textContent = '↺';
      reset.title = 'back to the default';
      reset.onclick = () => {
        const rest = { ...given };
        delete rest[p.name];
        edit([{ path: `techniques.${name}`, value: rest }]);
      };
      label.append(reset);
    }
    box.append(label);
  }
  // a long form (lightvol's 25 parameters) starts folded, so the sections
  // below it stay in reach; the user's choice holds until the next switch
  $('params-summary').textContent = `parameters (${info.params.length})`;
  if (box.dataset.technique !== name) $('params-box').open = info.params.length <= 10;
  box.dataset.technique = name;
}

// Progressive techniques never stop at one sample: switching to one from a
// one-sample scene also sets the limits the quick look uses (a target error
// and a time budget, shown in the status line); switching back to a
// one-pass technique drops exactly those limits again.
const AUTO_LIMITS = { spp: 4096, target_error: 0.02, time_ms: 10000 };
function autoLimits(r) {
  return r.spp === AUTO_LIMITS.spp && r.target_error === AUTO_LIMITS.target_error && r.time_ms === AUTO_LIMITS.time_ms;
}
$('technique').onchange = () => {
  const name = $('technique').value;
  const info = techniques.find((t) => t.name === name);
  const r = state.resolved.render;
  const edits = [{ path: 'render.technique', value: name }];
  if (info && info.progressive && r.spp <= 1 && !(r.time_ms > 0) && !(r.target_error > 0))
    for (const [k, v] of Object.entries(AUTO_LIMITS)) edits.push({ path: `render.${k}`, value: v });
  else if (info && !info.progressive && autoLimits(r))
    edits.push({ path: 'render.spp', value: 1 }, { path: 'render.target_error', value: 0 }, { path: 'render.time_ms', value: 0 });
  edit(edits);
};

// ---------------------------------------------------------------- material

function slider(id, toValue, fromValue, onInput) {
  const el = $(id), out = $(id + '-v');
  el.oninput = () => { out.textContent = fmt(toValue(Number(el.value))); onInput(toValue(Number(el.value))); };
  el.onpointerdown = () => dragging++;
  el.onpointerup = el.onpointercancel = () => { dragging = Math.max(0, dragging - 1); };
  return (v) => { el.value = fromValue(v); out.textContent = fmt(v); };
}
const fmt = (v) => (Math.abs(v) >= 100 ? v.toFixed(0) : Math.abs(v) >= 1 ? v.toFixed(2) : v.toPrecision(2));

const setAlbedo = slider('albedo', (x) => x, (v) => v, (v) => tfEdit({ albedo: v }));
const setG = slider('anisotropy', (x) => x, (v) => v, (v) => tfEdit({ anisotropy: v }));
const setDensity = slider('density', (x) => 10 ** x, (v) => Math.log10(Math.max(v, 1e-3)), (v) => tfEdit({ density_scale: Number(v.toPrecision(4)) }));

function refreshMaterial() {
  const r = resolvedTF();
  setAlbedo(r.albedo);
  setG(r.anisotropy);
  setDensity(r.density_scale);
}

// ---------------------------------------------------------------- transfer function

// Colour maps as sRGB stops (the published values of these maps, sampled);
// the TF holds linear colours, so the stops are decoded.
const PRESETS = {
  grayscale: ['#000000', '#ffffff'],
  viridis: ['#440154', '#472c7a', '#3b518b', '#2c718e', '#21908d', '#27ad81', '#5cc863', '#aadc32', '#fde725'],
  magma: ['#000004', '#1c1044', '#4f127b', '#812581', '#b5367a', '#e55964', '#fb8761', '#fec287', '#fcfdbf'],
  inferno: ['#000004', '#1f0c48', '#550f6d', '#88226a', '#ba3655', '#e35933', '#f98c0a', '#f9c932', '#fcffa4'],
  'cool to warm': ['#3b4cc0', '#6f92f3', '#aac7fd', '#dddcdc', '#f7b89c', '#e7755b', '#b40426'],
  bone: ['#000000', '#545474', '#a7c7c7', '#ffffff'],
  'black body': ['#000000', '#e62020', '#e6b020', '#ffffff'],
  'ct skin/bone': ['#3d1a0c', '#c9775a', '#f0c8a0', '#fff8ee'],
};
const srgbToLinear = (c) => (c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4);
const linearToSrgb = (c) => (c <= 0.0031308 ? 12.92 * c : 1.055 * c ** (1 / 2.4) - 0.055);
const hexToLinear = (h) => [1, 3, 5].map((i) => Number(srgbToLinear(parseInt(h.substr(i, 2), 16) / 255).toFixed(4)));
const linearToHex = (rgb) => '#' + rgb.map((c) => Math.round(Math.min(1, Math.max(0, linearToSrgb(c))) * 255).toString(16).padStart(2, '0')).join('');

{
  const sel = $('preset');
  sel.add(new Option('colour map…', ''));
  for (const name of Object.keys(PRESETS)) sel.add(new Option(name, name));
  sel.onchange = () => {
    const stops = PRESETS[sel.value];
    sel.value = '';
    if (!stops) return;
    const [lo, hi] = tfRange();
    const color = stops.map((h, i) => [Number((lo + (hi - lo) * i / (stops.length - 1)).toPrecision(6)), ...hexToLinear(h)]);
    resolvedTF().color = color;
    tfEdit({ color });
    drawTF();
  };
}

function tfRange() {
  let [lo, hi] = state.volume.range;
  if (!(hi > lo)) hi = lo + 1;
  return [lo, hi];
}

const tf = { sel: -1, csel: -1, drag: null };
const TF_PAD = 6;

function tfScaleY() {
  const pts = resolvedTF()[tfKey()];
  if (!resolvedTF().extinction) return 1;
  return Math.max(1e-6, ...pts.map((p) => p[1])) * 1.25;
}

function tfToCanvas(s, v, c, ymax) {
  const [lo, hi] = tfRange();
  return [TF_PAD + (s - lo) / (hi - lo) * (c.width - 2 * TF_PAD), c.height - TF_PAD - v / ymax * (c.height - 2 * TF_PAD)];
}

function tfFromCanvas(x, y, c, ymax) {
  const [lo, hi] = tfRange();
  const s = lo + (x - TF_PAD) / (c.width - 2 * TF_PAD) * (hi - lo);
  const v = (c.height - TF_PAD - y) / (c.height - 2 * TF_PAD) * ymax;
  return [Math.min(hi, Math.max(lo, s)), Math.min(ymax, Math.max(0, v))];
}

function colorAt(pts, s) {
  if (!pts.length) return [1, 1, 1];
  if (s <= pts[0][0]) return pts[0].slice(1);
  for (let i = 1; i < pts.length; i++)
    if (s <= pts[i][0]) {
      const a = pts[i - 1], b = pts[i], t = (s - a[0]) / Math.max(1e-12, b[0] - a[0]);
      return [1, 2, 3].map((k) => a[k] + t * (b[k] - a[k]));
    }
  return pts[pts.length - 1].slice(1);
}

function drawTF() {
  if (!state) return;
  const c = $('tf'), g = c.getContext('2d');
  const r = resolvedTF(), pts = r[tfKey()], ymax = tfScaleY();
  g.clearRect(0, 0, c.width, c.height);
  // histogram, log scale
  const h = state.volume.histogram, hmax = Math.log1p(Math.max(...h));
  g.fillStyle = '#3a3f47';
  const w = (c.width - 2 * TF_PAD) / h.length;
  h.forEach((n, i) => {
    const bh = Math.log1p(n) / hmax * (c.height - 2 * TF_PAD);
    g.fillRect(TF_PAD + i * w, c.height - TF_PAD - bh, Math.ceil(w), bh);
  });
  // opacity curve, filled with the colour map
  const grad = g.createLinearGradient(TF_PAD, 0, c.width - TF_PAD, 0);
  const [lo, hi] = tfRange();
  for (let i = 0; i <= 16; i++) {
    const s = lo + (hi - lo) * i / 16;
    grad.addColorStop(i / 16, linearToHex(colorAt(r.color, s)) + '90');
  }
  g.beginPath();
  const first = tfToCanvas(pts[0][0], pts[0][1], c, ymax);
  g.moveTo(TF_PAD, c.height - TF_PAD);
  g.lineTo(TF_PAD, first[1]);
  for (const p of pts) g.lineTo(...tfToCanvas(p[0], p[1], c, ymax));
  const last = tfToCanvas(pts[pts.length - 1][0], pts[pts.length - 1][1], c, ymax);
  g.lineTo(c.width - TF_PAD, last[1]);
  g.lineTo(c.width - TF_PAD, c.height - TF_PAD);
  g.closePath();
  g.fillStyle = grad;
  g.fill();
  g.strokeStyle = '#e8e8e8';
  g.lineWidth = 1.5;
  g.beginPath();
  pts.forEach((p, i) => { const [x, y] = tfToCanvas(p[0], p[1], c, ymax); i ? g.lineTo(x, y) : g.moveTo(x, y); });
  g.stroke();
  pts.forEach((p, i) => {
    const [x, y] = tfToCanvas(p[0], p[1], c, ymax);
    g.fillStyle = i === tf.sel ? '#e0a030' : '#ffffff';
    g.beginPath(); g.arc(x, y, 4.5, 0, 7); g.fill();
  });
  $('tf-unit').textContent = r.extinction ? `extinction σt (1/world unit), ${lo}…${hi}`
    : `opacity per ${r.opacity_unit_distance > 0 ? r.opacity_unit_distance : 'voxel spacing'}, ${lo}…${hi}`;
  // colour bar with its points
  const cb = $('tf-color'), cg = cb.getContext('2d');
  cg.clearRect(0, 0, cb.width, cb.height);
  for (let x = TF_PAD; x < cb.width - TF_PAD; x++) {
    const s = lo + (x - TF_PAD) / (cb.width - 2 * TF_PAD) * (hi - lo);
    cg.fillStyle = linearToHex(colorAt(r.color, s));
    cg.fillRect(x, 0, 1, cb.height - 8);
  }
  r.color.forEach((p, i) => {
    const x = tfToCanvas(p[0], 0, c, 1)[0];
    cg.fillStyle = i === tf.csel ? '#e0a030' : '#ffffff';
    cg.beginPath(); cg.moveTo(x, cb.height - 9); cg.lineTo(x - 5, cb.height); cg.lineTo(x + 5, cb.height); cg.fill();
  });
}

function canvasPos(c, ev) {
  const b = c.getBoundingClientRect();
  return [(ev.clientX - b.left) * c.width / b.width, (ev.clientY - b.top) * c.height / b.height];
}

function nearest(pts, xy, toXY, radius) {
  let best = -1, bd = radius * radius;
  pts.forEach((p, i) => {
    const [x, y] = toXY(p);
    const d = (x - xy[0]) ** 2 + (y - xy[1]) ** 2;
    if (d <= bd) { bd = d; best = i; }
  });
  return best;
}

function sendOpacity() {
  const key = tfKey(), pts = resolvedTF()[key].map((p) => [Number(p[0].toPrecision(6)), Number(p[1].toPrecision(5))]);
  tfEdit({ [key]: pts });
}

{
  const c = $('tf');
  const toXY = (p) => tfToCanvas(p[0], p[1], c, tfScaleY());
  c.addEventListener('pointerdown', (ev) => {
    if (!state || ev.button !== 0) return;
    const i = nearest(resolvedTF()[tfKey()], canvasPos(c, ev), toXY, 9);
    tf.sel = i;
    if (i >= 0) { tf.drag = { i, ymax: tfScaleY() }; dragging++; c.setPointerCapture(ev.pointerId); }
    drawTF();
  });
  c.addEventListener('pointermove', (ev) => {
    if (!tf.drag) return;
    const pts = resolvedTF()[tfKey()], i = tf.drag.i;
    let [s, v] = tfFromCanvas(...canvasPos(c, ev), c, tf.drag.ymax);
    // points stay sorted: a point moves between its neighbours
    if (i > 0) s = Math.max(s, pts[i - 1][0]);
    if (i < pts.length - 1) s = Math.min(s, pts[i + 1][0]);
    pts[i] = [s, v];
    drawTF();
    sendOpacity();
  });
  const end = () => { if (tf.drag) { tf.drag = null; dragging = Math.max(0, dragging - 1); } };
  c.addEventListener('pointerup', end);
  c.addEventListener('pointercancel', end);
  c.addEventListener('dblclick', (ev) => {
    const pts = resolvedTF()[tfKey()];
    const [s, v] = tfFromCanvas(...canvasPos(c, ev), c, tfScaleY());
    let k = pts.findIndex((p) => p[0] > s);
    if (k < 0) k = pts.length;
    pts.splice(k, 0, [s, v]);
    tf.sel = k;
    drawTF();
    sendOpacity();
  });
  c.addEventListener('contextmenu', (ev) => {
    ev.preventDefault();
    const pts = resolvedTF()[tfKey()];
    const i = nearest(pts, canvasPos(c, ev), toXY, 9);
    if (i < 0 || pts.length <= 1) return;
    pts.splice(i, 1);
    tf.sel = -1;
    drawTF();
    sendOpacity();
  });
  window.addEventListener('keydown', (ev) => {
    if ((ev.key === 'Delete' || ev.key === 'Backspace') && tf.sel >= 0 && document.activeElement === document.body) {
      const pts = resolvedTF()[tfKey()];
      if (pts.length > 1) { pts.splice(tf.sel, 1); tf.sel = -1; drawTF(); sendOpacity(); }
    }
  });
}

function sendColor() {
  const color = resolvedTF().color.map((p) => [Number(p[0].toPrecision(6)), ...p.slice(1).map((x) => Number(x.toFixed(4)))]);
  tfEdit({ color });
}

{
  const c = $('tf-color'), picker = $('tf-picker');
  const xOf = (p) => tfToCanvas(p[0], 0, $('tf'), 1)[0];
  let moved = false;
  c.addEventListener('pointerdown', (ev) => {
    if (!state || ev.button !== 0) return;
    const [x] = canvasPos(c, ev);
    tf.csel = nearest(resolvedTF().color, [x, 0], (p) => [xOf(p), 0], 7);
    moved = false;
    if (tf.csel >= 0) { tf.cdrag = true; dragging++; c.setPointerCapture(ev.pointerId); }
    drawTF();
  });
  c.addEventListener('pointermove', (ev) => {
    if (!tf.cdrag) return;
    const pts = resolvedTF().color, i = tf.csel;
    let [s] = tfFromCanvas(canvasPos(c, ev)[0], 0, $('tf'), 1);
    if (i > 0) s = Math.max(s, pts[i - 1][0]);
    if (i < pts.length - 1) s = Math.min(s, pts[i + 1][0]);
    pts[i][0] = s;
    moved = true;
    drawTF();
    sendColor();
  });
  c.addEventListener('pointerup', () => {
    if (!tf.cdrag) return;
    tf.cdrag = false;
    dragging = Math.max(0, dragging - 1);
    if (!moved && tf.csel >= 0) { // a click: choose the colour
      picker.value = linearToHex(resolvedTF().color[tf.csel].slice(1));
      picker.click();
    }
  });
  picker.addEventListener('input', () => {
    if (tf.csel < 0) return;
    resolvedTF().color[tf.csel].splice(1, 3, ...hexToLinear(picker.value));
    drawTF();
    sendColor();
  });
  c.addEventListener('dblclick', (ev) => {
    const pts = resolvedTF().color;
    const [s] = tfFromCanvas(canvasPos(c, ev)[0], 0, $('tf'), 1);
    let k = pts.findIndex((p) => p[0] > s);
    if (k < 0) k = pts.length;
    pts.splice(k, 0, [s, ...colorAt(pts, s)]);
    tf.csel = k;
    drawTF();
    sendColor();
  });
  c.addEventListener('contextmenu', (ev) => {
    ev.preventDefault();
    const pts = resolvedTF().color;
    const i = nearest(pts, [canvasPos(c, ev)[0], 0], (p) => [xOf(p), 0], 7);
    if (i < 0 || pts.length <= 1) return;
    pts.splice(i, 1);
    tf.csel = -1;
    drawTF();
    sendColor();
  });
}

// ---------------------------------------------------------------- camera

// The page's camera: orbit about a target (the volume's centre unless
// panned), distance in units of the bounding radius R as in the scene
// format. Unpanned it is sent as an orbit, panned as eye/look_at.
const cam = {
  az: 30, el: 20, dist: 3, target: [0, 0, 0], fov: 30,
  fromState() {
    const c = state.resolved.camera, C = state.volume.center, R = state.volume.radius;
    this.fov = c.fov_y;
    if (c.orbit) {
      this.az = c.azimuth; this.el = c.elevation; this.dist = c.distance; this.target = [...C];
    } else {
      const d = [0, 1, 2].map((k) => c.eye[k] - c.look_at[k]), n = Math.hypot(...d) || 1;
      this.dist = n / R;
      this.el = Math.asin(Math.max(-1, Math.min(1, d[1] / n))) * 180 / Math.PI;
      this.az = Math.atan2(d[0], d[2]) * 180 / Math.PI;
      this.target = [...c.look_at];
    }
    $('r-fov').value = this.fov;
    $('r-fov-v').textContent = this.fov.toFixed(0) + '°';
  },
  dir() { // unit vector from the target to the eye
    const a = this.az * Math.PI / 180, e = this.el * Math.PI / 180;
    return [Math.cos(e) * Math.sin(a), Math.sin(e), Math.cos(e) * Math.cos(a)];
  },
  basis() { // right, up, back (towards the viewer)
    const b = this.dir();
    let r = [b[2], 0, -b[0]];
    const n = Math.hypot(...r) || 1;
    r = r.map((x) => x / n);
    const u = [b[1] * r[2] - b[2] * r[1], b[2] * r[0] - b[0] * r[2], b[0] * r[1] - b[1] * r[0]];
    return [r, u, b];
  },
  send() {
    const C = state.volume.center, R = state.volume.radius;
    const json = state.scene.camera || {};
    const out = {};
    if (json.type) out.type = json.type;
    if (json.height !== undefined && json.type === 'orthographic') out.height = json.height;
    out.fov_y = Number(this.fov.toFixed(3));
    const round = (x) => Number(x.toPrecision(7));
    if (this.target.every((x, k) => Math.abs(x - C[k]) < 1e-6 * R)) {
      out.orbit = { azimuth: round(this.az), elevation: round(this.el), distance: round(this.dist) };
    } else {
      const d = this.dir();
      out.eye = d.map((x, k) => round(this.target[k] + x * this.dist * R));
      out.look_at = this.target.map(round);
      out.up = [0, 1, 0];
    }
    edit([{ path: 'camera', value: out }]);
  },
};

{
  const stage = $('stage');
  let last = null, mode = '';
  stage.addEventListener('pointerdown', (ev) => {
    if (!state) return;
    last = [ev.clientX, ev.clientY];
    mode = ev.button === 2 || ev.shiftKey ? 'pan' : 'orbit';
    stage.setPointerCapture(ev.pointerId);
    stage.classList.add('dragging');
    dragging++;
  });
  stage.addEventListener('pointermove', (ev) => {
    if (!last) return;
    const dx = ev.clientX - last[0], dy = ev.clientY - last[1];
    last = [ev.clientX, ev.clientY];
    if (mode === 'orbit') {
      cam.az -= dx * 0.4;
      cam.el = Math.max(-89.5, Math.min(89.5, cam.el + dy * 0.4));
    } else {
      const [r, u] = cam.basis(), R = state.volume.radius;
      const k = cam.dist * R * Math.tan(cam.fov * Math.PI / 360) * 2 / stage.clientHeight;
      cam.target = cam.target.map((x, i) => x - (dx * r[i] - dy * u[i]) * k);
    }
    cam.send();
  });
  const end = () => {
    if (!last) return;
    last = null;
    stage.classList.remove('dragging');
    dragging = Math.max(0, dragging - 1);
  };
  stage.addEventListener('pointerup', end);
  stage.addEventListener('pointercancel', end);
  stage.addEventListener('contextmenu', (ev) => ev.preventDefault());
  stage.addEventListener('wheel', (ev) => {
    if (!state) return;
    ev.preventDefault();
    cam.dist = Math.max(0.05, Math.min(1e4, cam.dist * Math.exp(ev.deltaY * 0.0015)));
    cam.send();
  }, { passive: false });
  stage.addEventListener('dblclick', () => {
    cam.target = [...state.volume.center];
    cam.dist = 1 / Math.sin(cam.fov * Math.PI / 360);
    cam.send();
  });
  $('r-fov').oninput = () => {
    cam.fov = Number($('r-fov').value);
    $('r-fov-v').textContent = cam.fov.toFixed(0) + '°';
    cam.send();
  };
}

// ---------------------------------------------------------------- lights

const STRENGTH = { directional: 'irradiance', point: 'intensity', spot: 'intensity', sphere: 'radiance' };
const strengthKey = (l) => (l.type === 'environment' ? (l.file ? 'intensity' : 'radiance') : STRENGTH[l.type]);

function lightsJSON() { return state.scene.lights || []; }

function refreshLights() {
  const box = $('lights');
  box.replaceChildren();
  lightsJSON().forEach((l, i) => box.append(lightCard(l, i)));
}

function lightCard(l, i) {
  const card = document.createElement('div');
  card.className = 'light' + (l.enabled === false ? ' off' : '');
  card.dataset.index = i;
  const head = document.createElement('div');
  head.className = 'head';
  const on = document.createElement('input');
  on.type = 'checkbox';
  on.checked = l.enabled !== false;
  on.title = 'on/off';
  on.className = 'toggle';
  on.onchange = () => edit([{ path: `lights.${i}.enabled`, value: on.checked }]);
  const name = document.createElement('span');
  name.className = 'name';
  name.textContent = `${i}: ${l.type}${l.file ? ' (' + l.file + ')' : ''}`;
  const color = document.createElement('input');
  color.type = 'color';
  color.value = linearToHex(l.color || [1, 1, 1]);
  color.oninput = () => edit([{ path: `lights.${i}.color`, value: hexToLinear(color.value) }]);
  const del = document.createElement('button');
  del.textContent = '✕';
  del.title = 'remove';
  del.className = 'remove';
  del.onclick = () => edit([{ path: 'lights', value: lightsJSON().filter((_, k) => k !== i) }]);
  head.append(on, name, color, del);
  card.append(head);
  // strength: a log slider around the current value
  const key = strengthKey(l), val = l[key] !== undefined ? l[key] : 1;
  const lab = document.createElement('label');
  const s = document.createElement('input');
  s.type = 'range'; s.min = -3; s.max = 6; s.step = 0.01;
  s.value = Math.log10(Math.max(val, 1e-3));
  const out = document.createElement('output');
  out.textContent = fmt(val);
  s.onpointerdown = () => dragging++;
  s.onpointerup = s.onpointercancel = () => { dragging = Math.max(0, dragging - 1); };
  s.oninput = () => {
    const v = Number((10 ** Number(s.value)).toPrecision(4));
    out.textContent = fmt(v);
    edit([{ path: `lights.${i}.${key}`, value: v }]);
  };
  lab.append(key, s, out);
  card.append(lab);
  if (l.type === 'spot') {
    for (const [k, lo, hi, d] of [['cone_angle', 1, 90, 30], ['falloff_angle', 0, 90, 24]]) {
      const a = document.createElement('label');
      const r = document.createElement('input');
      r.type = 'range'; r.min = lo; r.max = hi; r.step = 0.5; r.value = l[k] !== undefined ? l[k] : d;
      r.oninput = () => edit([{ path: `lights.${i}.${k}`, value: Number(r.value) }]);
      a.append(k.replace('_angle', ''), r);
      card.append(a);
    }
  }
  if (l.type === 'sphere') {
    const a = document.createElement('label');
    const r = document.createElement('input');
    r.type = 'number'; r.min = 1e-6; r.step = 'any'; r.value = l.radius !== undefined ? l.radius : 1;
    r.onchange = () => edit([{ path: `lights.${i}.radius`, value: Number(r.value) }]);
    a.append('radius', r);
    card.append(a);
  }
  if (l.type === 'environment') {
    const a = document.createElement('label');
    const r = document.createElement('input');
    r.type = 'range'; r.min = -180; r.max = 180; r.step = 1; r.value = l.rotation_y || 0;
    r.oninput = () => edit([{ path: `lights.${i}.rotation_y`, value: Number(r.value) }]);
    a.append('rotate', r);
    card.append(a);
  } else {
    card.append(gizmo(l, i));
  }
  return card;
}

// Where the light comes from, in view space: a sphere seen from the camera;
// dragging on it moves the light (front half; shift: back half).
function gizmo(l, i) {
  const c = document.createElement('canvas');
  c.width = c.height = 84;
  c.className = 'gizmo';
  c.title = 'drag: where the light comes from (shift: from behind)';
  const C = state.volume.center, R = state.volume.radius;
  const fromWorld = () => {
    if (l.type === 'directional') return (l.direction || [0, 0, -1]).map((x) => -x);
    const p = l.position || [0, 0, 0];
    return p.map((x, k) => x - C[k]);
  };
  const draw = () => {
    const g = c.getContext('2d'), [r, u, b] = cam.basis();
    let f = fromWorld();
    const n = Math.hypot(...f) || 1;
    f = f.map((x) => x / n);
    const x = f[0] * r[0] + f[1] * r[1] + f[2] * r[2], y = f[0] * u[0] + f[1] * u[1] + f[2] * u[2];
    const z = f[0] * b[0] + f[1] * b[1] + f[2] * b[2];
    g.clearRect(0, 0, 84, 84);
    const grad = g.createRadialGradient(42 + x * 30, 42 - y * 30, 2, 42, 42, 38);
    grad.addColorStop(0, z >= 0 ? '#fff4d0' : '#6a6a6a');
    grad.addColorStop(1, '#23272d');
    g.fillStyle = grad;
    g.beginPath(); g.arc(42, 42, 38, 0, 7); g.fill();
    g.strokeStyle = '#555'; g.stroke();
    g.fillStyle = z >= 0 ? '#e0a030' : '#806030';
    g.beginPath(); g.arc(42 + x * 38, 42 - y * 38, 5, 0, 7); g.fill();
  };
  const set = (ev) => {
    const [px, py] = canvasPos(c, ev);
    let x = (px - 42) / 38, y = (42 - py) / 38;
    const n2 = x * x + y * y;
    if (n2 > 1) { const n = Math.sqrt(n2); x /= n; y /= n; }
    const z = Math.sqrt(Math.max(0, 1 - x * x - y * y)) * (ev.shiftKey ? -1 : 1);
    const [r, u, b] = cam.basis();
    const f = [0, 1, 2].map((k) => x * r[k] + y * u[k] + z * b[k]);
    const round = (v) => Number(v.toPrecision(6));
    if (l.type === 'directional') {
      l.direction = f.map((v) => round(-v));
      edit([{ path: `lights.${i}.direction`, value: l.direction }]);
    } else {
      const d = Math.hypot(...fromWorld()) || 2 * R;
      l.position = f.map((v, k) => round(C[k] + v * d));
      const list = [{ path: `lights.${i}.position`, value: l.position }];
      if (l.type === 'spot') { l.direction = f.map((v) => round(-v)); list.push({ path: `lights.${i}.direction`, value: l.direction }); }
      edit(list);
    }
    draw();
  };
  let active = false;
  c.addEventListener('pointerdown', (ev) => { active = true; dragging++; c.setPointerCapture(ev.pointerId); set(ev); });
  c.addEventListener('pointermove', (ev) => { if (active) set(ev); });
  const end = () => { if (active) { active = false; dragging = Math.max(0, dragging - 1); } };
  c.addEventListener('pointerup', end);
  c.addEventListener('pointercancel', end);
  draw();
  return c;
}

$('light-add').onclick = () => {
  const type = $('light-type').value, C = state.volume.center, R = state.volume.radius;
  const [r, u, b] = cam.basis();
  // from the upper right of the current view
  const f = [0, 1, 2].map((k) => 0.5 * r[k] + 0.5 * u[k] + 0.7 * b[k]);
  const round = (v) => Number(v.toPrecision(6));
  const pos = f.map((v, k) => round(C[k] + 2.5 * R * v));
  const light = {
    directional: { type, direction: f.map((v) => round(-v)), irradiance: 1 },
    point: { type, position: pos, intensity: round(6 * R * R) },
    spot: { type, position: pos, direction: f.map((v) => round(-v)), intensity: round(6 * R * R), cone_angle: 25 },
    sphere: { type, position: pos, radius: round(0.15 * R), radiance: 10 },
    environment: { type, radiance: 0.3 },
  }[type];
  edit([{ path: `lights.${lightsJSON().length}`, value: light }]);
};

// ---------------------------------------------------------------- crop and clip (issue 30)
// The scene's "clip" section (docs/CLIP.md): a crop box by six sliders over
// the volume's box and up to 6 planes (a position along the normal, the
// normal). Each change is one edit of the whole box or the whole plane list.

const CLIP_MAX_PLANES = 6;
const CLIP_AXES = ['x', 'y', 'z'];
const clipJSON = () => state.scene.clip || {};
const clipRound = (v) => Number(v.toPrecision(6));

function clipBox() {
  const b = clipJSON().box || {}, lo = state.volume.box_min, hi = state.volume.box_max;
  return { min: [0, 1, 2].map((a) => (b.min ? b.min[a] : lo[a])), max: [0, 1, 2].map((a) => (b.max ? b.max[a] : hi[a])) };
}

function clipSet(key, value) {
  state.scene.clip = { ...clipJSON(), [key]: value }; // the next drag step sees it at once
  edit([{ path: 'clip.' + key, value }]);
}

function buildClipBox() {
  const el = $('clip-box');
  for (const end of ['min', 'max'])
    for (let a = 0; a < 3; a++) {
      const label = document.createElement('label');
      const input = document.createElement('input');
      const out = document.createElement('output');
      input.type = 'range';
      input.id = `clip-${end}-${CLIP_AXES[a]}`;
      out.id = input.id + '-v';
      label.append(`${CLIP_AXES[a]} ${end}`, input, out);
      el.append(label);
      input.oninput = () => {
        const box = clipBox(), v = Number(input.value), other = end === 'min' ? 'max' : 'min';
        box[end][a] = v;
        if (box.min[a] > box.max[a]) box[other][a] = v; // the other side gives way
        out.textContent = fmt(v);
        clipSet('box', { min: box.min.map(clipRound), max: box.max.map(clipRound) });
      };
    }
}

function planeOffset(p) {
  const C = state.volume.center, n = p.normal, len = Math.hypot(...n) || 1;
  return ((p.origin[0] - C[0]) * n[0] + (p.origin[1] - C[1]) * n[1] + (p.origin[2] - C[2]) * n[2]) / len;
}

function planeCard(p, i) {
  const planes = () => (clipJSON().planes || []).map((q) => ({ origin: [...q.origin], normal: [...q.normal] }));
  const card = document.createElement('div');
  card.className = 'light clip-plane';
  card.dataset.index = i;
  const head = document.createElement('div');
  head.className = 'head';
  const name = document.createElement('span');
  name.className = 'name';
  name.textContent = `plane ${i + 1}`;
  const del = document.createElement('button');
  del.textContent = 'remove';
  del.className = 'clip-plane-remove';
  del.onclick = () => clipSet('planes', planes().filter((_, k) => k !== i));
  head.append(name, del);
  card.append(head);
  // position: the origin moved along the normal through the volume's centre
  const R = state.volume.radius, pos = document.createElement('label');
  const r = document.createElement('input');
  r.type = 'range'; r.min = -R; r.max = R; r.step = R / 200; r.value = planeOffset(p);
  r.className = 'clip-plane-offset';
  r.oninput = () => {
    const list = planes(), q = list[i], n = q.normal, len = Math.hypot(...n) || 1, C = state.volume.center;
    q.origin = [0, 1, 2].map((a) => clipRound(C[a] + (Number(r.value) * n[a]) / len));
    clipSet('planes', list);
  };
  pos.append('position', r);
  card.append(pos);
  const nrm = document.createElement('label');
  nrm.append('normal');
  for (let a = 0; a < 3; a++) {
    const x = document.createElement('input');
    x.type = 'number'; x.step = 0.1; x.value = p.normal[a];
    x.className = 'clip-plane-normal';
    x.style.flex = '0 0 3.6em'; x.style.width = '3.6em';
    x.onchange = () => {
      const list = planes(), v = Number(x.value);
      if (x.value === '' || !Number.isFinite(v)) return;
      list[i].normal[a] = v;
      clipSet('planes', list);
    };
    nrm.append(x);
  }
  card.append(nrm);
  return card;
}

function refreshClip() {
  if (!$('clip-box').children.length) buildClipBox();
  const box = clipBox(), lo = state.volume.box_min, hi = state.volume.box_max;
  for (const end of ['min', 'max'])
    for (let a = 0; a < 3; a++) {
      const input = $(`clip-${end}-${CLIP_AXES[a]}`);
      input.min = lo[a]; input.max = hi[a]; input.step = (hi[a] - lo[a]) / 200 || 1;
      if (document.activeElement !== input) {
        input.value = box[end][a];
        $(input.id + '-v').textContent = fmt(box[end][a]);
      }
    }
  const el = $('clip-planes');
  if (el.contains(document.activeElement)) return; // keep the control being used
  el.replaceChildren(...(clipJSON().planes || []).map(planeCard));
  $('clip-plane-add').disabled = (clipJSON().planes || []).length >= CLIP_MAX_PLANES;
}

$('clip-box-reset').onclick = () => {
  if (!clipJSON().box) return;
  clipSet('box', null);
};
$('clip-plane-add').onclick = () => {
  const list = (clipJSON().planes || []).slice();
  if (list.length >= CLIP_MAX_PLANES) return;
  list.push({ origin: state.volume.center.map(clipRound), normal: [1, 0, 0] });
  clipSet('planes', list);
  refreshClip();
};

// ---------------------------------------------------------------- render, time

function refreshRender() {
  const r = state.resolved.render;
  for (const [id, v] of [['r-width', r.width], ['r-height', r.height], ['r-spp', r.spp], ['r-step', r.step]])
    if (document.activeElement !== $(id)) $(id).value = v;
  $('r-width').max = $('r-height').max = state.limits.max_image;
  $('r-exposure').value = r.exposure;
  $('r-exposure-v').textContent = Number(r.exposure).toFixed(1);
  const seq = state.sequence;
  $('sec-time').hidden = !seq;
  if (seq) {
    $('time-step').max = seq.steps - 1;
    if (document.activeElement !== $('time-step')) {
      $('time-step').value = seq.step;
      $('time-step-v').textContent = seq.step;
    }
  }
}

for (const [id, key, int] of [['r-width', 'width', 1], ['r-height', 'height', 1], ['r-spp', 'spp', 1], ['r-step', 'step', 0]])
  $(id).onchange = () => {
    const v = Number($(id).value);
    if ($(id).value !== '' && Number.isFinite(v)) edit([{ path: 'render.' + key, value: int ? Math.round(v) : v }]);
  };
$('r-exposure').oninput = () => {
  $('r-exposure-v').textContent = Number($('r-exposure').value).toFixed(1);
  edit([{ path: 'render.exposure', value: Number($('r-exposure').value) }]);
};
$('time-step').oninput = () => {
  $('time-step-v').textContent = $('time-step').value;
  edit([{ path: 'render.time_step', value: Number($('time-step').value) }]);
};


// ---------------------------------------------------------------- view: exposure, denoise, background, view buttons

// The viewer's own switches (POST /api/view; not part of the scene).
async function viewSwitch(body) {
  const r = await api('/api/view', { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
  if (!r.ok) { showError((await r.json()).error); return; }
  const v = await r.json();
  $('v-auto-exposure').checked = v.auto_exposure;
  $('v-denoise').checked = v.denoise;
}
let viewSwitchesRead = false;
function refreshView() {
  if (!viewSwitchesRead && state.viewer) { // the start-up switches; the page's own clicks after that
    $('v-auto-exposure').checked = state.viewer.auto_exposure;
    $('v-denoise').checked = state.viewer.denoise;
    viewSwitchesRead = true;
  }
  // the background as displayed: ×2^exposure (what the PNG shows)
  const bg = state.scene.background || [0, 0, 0], k = 2 ** state.resolved.render.exposure;
  if (document.activeElement !== $('v-background')) $('v-background').value = linearToHex(bg.map((c) => c * k));
  drawAxes();
}
$('v-auto-exposure').onchange = () => viewSwitch({ auto_exposure: $('v-auto-exposure').checked });
$('v-expose').onclick = () => viewSwitch({ expose: true });
$('v-denoise').onchange = () => viewSwitch({ denoise: $('v-denoise').checked });
$('v-background').oninput = () => {
  const k = 2 ** -state.resolved.render.exposure;
  edit([{ path: 'background', value: hexToLinear($('v-background').value).map((c) => Number((c * k).toPrecision(5))) }]);
};

// Patient axes: with an anatomical orientation in the file (state.volume.
// superior) the world axes are NIfTI's RAS+ (x right, y anterior, z
// superior); without one, y is up (the orbit camera's), z towards the
// default viewer, x to the right.
function patientAxes() {
  return state.volume.superior ? { R: [1, 0, 0], A: [0, 1, 0], S: [0, 0, 1] } : { R: [1, 0, 0], A: [0, 0, 1], S: [0, 1, 0] };
}
const VIEWS = { // where the eye is, and which axis is up on screen
  anterior: ['A', 1, 'S'], posterior: ['A', -1, 'S'], left: ['R', -1, 'S'],
  right: ['R', 1, 'S'], superior: ['S', 1, 'A'], inferior: ['S', -1, 'A'],
};
for (const b of document.querySelectorAll('#v-views button')) {
  b.title = `view from the ${b.dataset.view} side`;
  b.onclick = () => {
    const ax = patientAxes(), [axis, sign, up] = VIEWS[b.dataset.view];
    const C = state.volume.center, R = state.volume.radius, d = (1 / Math.sin(cam.fov * Math.PI / 360)) * R;
    const round = (x) => Number(x.toPrecision(7));
    const camera = { fov_y: Number(cam.fov.toFixed(3)) };
    if (state.scene.camera && state.scene.camera.type) camera.type = state.scene.camera.type;
    camera.eye = C.map((c, k) => round(c + sign * ax[axis][k] * d));
    camera.look_at = C.map(round);
    camera.up = ax[up];
    edit([{ path: 'camera', value: camera }]);
  };
}
// The orientation axes: the world axes projected with the camera's basis.
function drawAxes() {
  const c = $('v-axes'), g = c.getContext('2d'), r = state.resolved.camera;
  g.clearRect(0, 0, c.width, c.height);
  const back = [0, 1, 2].map((k) => r.eye[k] - r.look_at[k]), n = Math.hypot(...back);
  const cross = (p, q) => [p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0]];
  let [right, up, b] = cam.basis(); // an orbit (y up) unless the scene has eye/look_at/up
  if (n > 0 && Math.hypot(...cross(r.up, back)) > 0) {
    b = back.map((x) => x / n);
    right = cross(r.up, b);
    const rn = Math.hypot(...right);
    right = right.map((x) => x / rn);
    up = cross(b, right);
  }
  const dot = (p, q) => p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
  const ax = patientAxes(), med = !!state.volume.superior;
  const axes = [[ax.R, '#e05050', med ? 'R' : 'x'], [ax.A, '#50c050', med ? 'A' : (ax.A[2] ? 'z' : 'y')], [ax.S, '#5080e0', med ? 'S' : 'y']];
  axes.sort((p, q) => dot(p[0], b) - dot(q[0], b)); // far ones first
  const m = c.width / 2;
  for (const [v, col, name] of axes) {
    const x = m + dot(v, right) * m * 0.7, y = m - dot(v, up) * m * 0.7;
    g.strokeStyle = g.fillStyle = col;
    g.lineWidth = 2;
    g.beginPath(); g.moveTo(m, m); g.lineTo(x, y); g.stroke();
    g.font = '11px sans-serif';
    g.fillText(name, x + (x >= m ? 2 : -9), y + (y >= m ? 10 : -2));
  }
}

// ---------------------------------------------------------------- slices (GET /api/slice)

const sliceState = { timer: 0, key: '' };
function sliceURL(axis) {
  const [lo, hi] = state.volume.range, span = hi - lo || 1;
  const q = new URLSearchParams({ axis, index: $(`slice-${axis}-i`).value, mode: $('s-mode').value });
  if ($('s-mode').value === 'grey') {
    q.set('window', String(Number($('s-window').value) * span));
    q.set('level', String(lo + Number($('s-level').value) * span));
  }
  return '/api/slice?' + q;
}
async function loadSlice(axis) {
  const r = await api(sliceURL(axis));
  if (!r.ok) { showError(`slice ${axis}: ${(await r.json()).error}`); return; }
  const url = URL.createObjectURL(await r.blob()), img = $(`slice-${axis}`);
  const old = img.src;
  img.src = url;
  if (old.startsWith('blob:')) URL.revokeObjectURL(old);
  // the voxel aspect (spacing) of the slice's two axes
  const sp = state.volume.spacing, d = state.volume.dims, u = axis === 'x' ? 1 : 0, w = axis === 'z' ? 1 : 2;
  img.style.aspectRatio = `${d[u] * sp[u]} / ${d[w] * sp[w]}`;
}
function refreshSlices() {
  if (!$('sec-slices').open) return;
  const [lo, hi] = state.volume.range, span = hi - lo || 1;
  $('s-window-v').textContent = fmt(Number($('s-window').value) * span);
  $('s-level-v').textContent = fmt(lo + Number($('s-level').value) * span);
  // a new volume (or the first look): the sliders' ranges, in the middle
  const key = state.volume.dims.join('x') + ':' + state.version;
  for (const [k, axis] of ['x', 'y', 'z'].entries()) {
    const s = $(`slice-${axis}-i`);
    if (Number(s.max) !== state.volume.dims[k] - 1) {
      s.max = state.volume.dims[k] - 1;
      s.value = Math.floor(state.volume.dims[k] / 2);
    }
  }
  // slices show the raw volume (and the TF colours): only an edit may change them
  if (key === sliceState.key) return;
  sliceState.key = key;
  for (const axis of ['x', 'y', 'z']) loadSlice(axis);
}
for (const axis of ['x', 'y', 'z']) $(`slice-${axis}-i`).oninput = () => loadSlice(axis);
for (const id of ['s-mode', 's-window', 's-level'])
  $(id).oninput = () => { sliceState.key = ''; refreshSlices(); };
$('sec-slices').addEventListener('toggle', () => { sliceState.key = ''; if (state) refreshSlices(); });

// ---------------------------------------------------------------- save

async function download(path, name) {
  const r = await api(path);
  if (!r.ok) {
    let msg = r.statusText;
    try { msg = (await r.json()).error; } catch (e) { /* not JSON */ }
    showError(`${name}: ${msg}`);
    return;
  }
  const url = URL.createObjectURL(await r.blob());
  const a = document.createElement('a');
  a.href = url;
  a.download = name;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}

// Absolute file names: the saved scene renders the same from any folder.
$('save-scene').onclick = () => download('/api/scene?paths=absolute', 'scene.json');
// The final frame of the current scene (waits for refinement to finish).
$('save-image').onclick = () => download('/api/frame?wait=final&format=png&timeout=120000', 'volux.png');

// ---------------------------------------------------------------- stats

async function pollStats() {
  if ($('sec-stats').open) {
    try {
      const r = await api('/api/stats');
      if (r.ok) {
        const s = await r.json();
        s.page_edit_to_frame_ms_median = Number(median(latencies).toFixed(1));
        s.page_edits_measured = latencies.length;
        $('stats').textContent = JSON.stringify(s, null, 1);
      }
    } catch (e) { /* the stream shows the connection state */ }
  }
  setTimeout(pollStats, 1000);
}

// ---------------------------------------------------------------- start

(async () => {
  const r = await api('/api/techniques');
  techniques = r.ok ? await r.json() : [];
  await loadState();
  connect();
  pollStats();
  window.volux.edit = edit;
  window.volux.ready = true;
})();
