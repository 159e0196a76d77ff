// The page: connects to the simulator's feed, keeps the 3D view, the panels and the plots up to
// date, and sends the control area's commands.
import { Feed } from './feed.js';
import { View3D } from './view3d.js';
import { History, drawJoints, drawLatency } from './plots.js';

const $ = (id) => document.getElementById(id);
const view = new View3D($('view'));
const history = new History(10);
let sceneMsg = null;
let lastState = null;
let lastLost = null;
const t0 = performance.now();
const now = () => (performance.now() - t0) / 1000;

function toast(text, kind = 'error') {
  const el = $('toast');
  el.textContent = text;
  el.className = `toast ${kind === 'info' ? 'info' : ''}`;
  el.hidden = false;
  clearTimeout(toast.timer);
  toast.timer = setTimeout(() => { el.hidden = true; }, 3500);
}

// --- data area 1: joints ----------------------------------------------------------------------
function buildJoints(joints) {
  const box = $('joints');
  box.innerHTML = '';
  for (const j of joints) {
    const row = document.createElement('div');
    row.className = 'joint';
    row.id = `joint-${j.name}`;
    row.innerHTML = `<span class="name">${j.name}</span>
      <span class="value">—</span>
      <span class="unit">${j.unit === 'deg' ? '°' : j.unit}</span>
      <div class="bar"><em title="commanded"></em><i title="measured"></i></div>
      <span class="lim" style="grid-column:1/span 3">${j.min_display.toFixed(0)} … ${j.max_display.toFixed(0)} ${j.unit === 'deg' ? '°' : j.unit}<span class="phys"></span></span>`;
    box.appendChild(row);
  }
}

function barPos(j, v) {
  const f = (v - j.min_display) / (j.max_display - j.min_display);
  return `${Math.max(0, Math.min(1, f)) * 100}%`;
}

function updateJoints(state) {
  const joints = sceneMsg.joints;
  const phys = state.link.physical;
  joints.forEach((j, i) => {
    const row = $(`joint-${j.name}`);
    if (!row) return;
    const v = state.display[i];
    row.querySelector('.value').textContent = v.toFixed(i === 0 ? 1 : 1);
    row.querySelector('.bar i').style.left = barPos(j, v);
    row.querySelector('.bar em').style.left = barPos(j, state.targets_display[i]);
    row.classList.toggle('out', state.out_of_limit[i]);
    row.querySelector('.phys').textContent = phys ? ` · physical ${phys[i].toFixed(1)}` : '';
  });
  const g = state.gripper;
  $('gripper').textContent = `gripper ${g.closed ? 'closed' : 'open'}${g.held >= 0 ? ` · holding cube ${g.held}` : ''}` +
    (state.trajectory ? ' · following a trajectory' : '');
  const wc = $('warn-count');
  wc.textContent = state.warnings_total ? `${state.warnings_total} limit warning${state.warnings_total > 1 ? 's' : ''}` : 'within limits';
  wc.classList.toggle('on', state.warnings_total > 0);
}

// --- link and mode ----------------------------------------------------------------------------
function updateLink(state) {
  for (const el of $('mode').children) el.classList.toggle('on', el.dataset.mode === state.twin_mode);
  const l = state.link;
  const ls = $('link-state');
  ls.textContent = l.connected ? 'connected' : 'no hub';
  ls.className = l.connected ? 'ok' : 'bad';
  $('lat').textContent = l.latency_ms !== undefined ? `${l.latency_ms.toFixed(2)} ms` : '—';
  $('lat-mean').textContent = l.latency_mean_ms !== undefined ? `${l.latency_mean_ms.toFixed(2)} / ${l.latency_max_ms.toFixed(2)} ms` : '—';
  $('frames').textContent = l.frames;
  const lost = $('lost');
  lost.textContent = l.lost;
  lost.className = l.lost > 0 ? 'warn' : '';
  $('rate').textContent = l.frames ? `${l.rate_hz.toFixed(0)} Hz` : '—';
  $('sim-time').textContent = `t ${state.t.toFixed(1)} s`;
  $('rtf').textContent = `× ${state.rtf.toFixed(2)}`;
  $('clients').textContent = `${state.clients} viewer${state.clients === 1 ? '' : 's'}`;
  const tool = state.tool;
  $('tool-readout').textContent = `tool  x ${(tool.x * 1e3).toFixed(1)}  y ${(tool.y * 1e3).toFixed(1)}  z ${(tool.z * 1e3).toFixed(1)} mm  yaw ${(tool.yaw * 180 / Math.PI).toFixed(1)}°`;
}

// --- a workcell of several robots: each one's mode, joints and gripper ------------------------
function updateRobots(state) {
  const robots = state.robots || [];
  $('robots-card').hidden = robots.length === 0;
  if (robots.length === 0) return;
  const rows = robots.map((r) => {
    const j = r.display.map((v) => v.toFixed(1)).map((v) => `<td>${v}</td>`).join('');
    const grip = r.gripper.closed ? (r.gripper.held >= 0 ? `#${r.gripper.held}` : 'closed') : 'open';
    // its hub's link, on a line of its own: up or down, rate, frames lost, mean latency
    const l = r.link;
    const latency = l && l.latency_mean_ms !== undefined ? ` · ${l.latency_mean_ms.toFixed(2)} ms` : '';
    const link = !l ? '' : `<tr class="robot-link" data-link="${r.name}"><td></td><td colspan="6">` +
      (l.connected ? `link ${l.rate_hz.toFixed(0)}/s · ${l.lost} lost${latency}` : 'link down') + '</td></tr>';
    return `<tr data-robot="${r.name}"><td>${r.name}</td><td>${r.mode}</td>${j}<td>${grip}</td></tr>${link}`;
  }).join('');
  const tbody = $('robot-list');
  if (tbody.dataset.html !== rows) {
    tbody.innerHTML = rows;
    tbody.dataset.html = rows;
  }
  $('robot-count').textContent = robots.length;
  const touches = state.arm_touches || 0;
  $('arm-touches').textContent = touches === 0 ? 'arms never touched' : `arms touched ${touches}×`;
  $('arm-touches').classList.toggle('alarm', touches > 0);
}

// --- data area 2: cubes -----------------------------------------------------------------------
function updateCubes(state) {
  const tbody = $('cube-list');
  const rows = state.cubes.map((c) => {
    const [x, y, z] = c.pos.map((v) => (v * 1e3).toFixed(1));
    return `<tr data-id="${c.id}" data-color="${c.color}" class="${c.held ? 'held' : ''}"><td><span class="dot ${c.color}" title="${c.color}"></span></td><td>${c.id}</td><td>${x}</td><td>${y}</td><td>${z}</td></tr>`;
  }).join('');
  if (tbody.dataset.html !== rows) {
    tbody.innerHTML = rows;
    tbody.dataset.html = rows;
  }
  $('cube-count').textContent = state.cubes.length;
  $('cube-empty').hidden = state.cubes.length > 0;
}

// --- plots ------------------------------------------------------------------------------------
function record(state) {
  const l = state.link;
  history.push({
    t: now(),
    virtual: state.display,
    physical: l.physical || null,
    latency: l.latency_ms !== undefined && l.connected ? l.latency_ms : null,
    latencyMax: l.latency_max_ms !== undefined && l.connected ? l.latency_max_ms : null,
    lost: l.lost,
  });
  lastLost = l.lost;
}

function drawPlots() {
  const t = now();
  drawJoints($('plot-joints'), history, t, sceneMsg ? sceneMsg.joints : null);
  drawLatency($('plot-latency'), history, t);
}
setInterval(drawPlots, 100);

// --- feed -------------------------------------------------------------------------------------
// a simulator serving beyond this machine asks for its access token (docs/security.md): the
// page passes on the one it was opened with (?token=...)
const token = new URLSearchParams(location.search).get('token');
const wsUrl = `${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws` +
  (token ? `?token=${encodeURIComponent(token)}` : '');
const feed = new Feed(wsUrl, {
  onStatus(status) {
    const pill = $('conn');
    pill.className = `pill ${status}`;
    pill.querySelector('b').textContent = status === 'live' ? 'live' : status === 'down' ? 'offline' : 'connecting…';
    document.body.classList.toggle('disconnected', status === 'down');
  },
  onMessage(msg) {
    if (msg.type === 'scene') {
      sceneMsg = msg;
      // the fleet page, when this simulator watches a broker (scaratwin-sim --mqtt)
      const fleetLink = $('fleet-link');
      if (token) fleetLink.href = `fleet.html?token=${encodeURIComponent(token)}`;
      fleetLink.hidden = !msg.fleet;
      view.build(msg);
      buildJoints(msg.joints);
    } else if (msg.type === 'state' && sceneMsg) {
      lastState = msg;
      view.update(msg);
      updateJoints(msg);
      updateLink(msg);
      updateCubes(msg);
      updateRobots(msg);
      record(msg);
    } else if (msg.type === 'reply' && !msg.ok && msg.id === undefined) {
      toast(msg.error);
    }
  },
});

// --- control area -----------------------------------------------------------------------------
function readCoord(id) {
  const v = $(id).value.trim();
  return v === '' ? null : Number(v);
}

for (const btn of document.querySelectorAll('.cube-btn')) {
  btn.addEventListener('click', async () => {
    const x = readCoord('spawn-x');
    const y = readCoord('spawn-y');
    if ((x === null) !== (y === null)) {
      toast('Type both x and y, or leave both empty for a random free spot.');
      return;
    }
    const cmd = { cmd: 'spawn', color: btn.dataset.color };
    if (x !== null) Object.assign(cmd, { x_mm: x, y_mm: y });
    const r = await feed.request(cmd);
    if (!r.ok) toast(r.error);
  });
}

$('reset').addEventListener('click', async () => {
  const r = await feed.request({ cmd: 'reset' });
  if (!r.ok) toast(r.error);
});

$('shoot').addEventListener('click', async () => {
  const btn = $('shoot');
  btn.disabled = true;
  const r = await feed.request({ cmd: 'shoot' });
  btn.disabled = false;
  if (r.type !== 'image') {
    toast(r.error || 'no picture');
    return;
  }
  const url = `data:image/png;base64,${r.png_base64}`;
  $('shot-img').src = url;
  $('shot-info').textContent = `${r.width}×${r.height} px · ${(r.bytes / 1024).toFixed(0)} KiB · at t ${lastState ? lastState.t.toFixed(1) : '—'} s`;
  $('shot').hidden = false;
});

$('shot-img').addEventListener('click', () => {
  $('modal-img').src = $('shot-img').src;
  $('modal').hidden = false;
});
$('modal').addEventListener('click', () => { $('modal').hidden = true; });
$('shot-close').addEventListener('click', () => { $('shot').hidden = true; });

for (const b of document.querySelectorAll('[data-view]')) b.addEventListener('click', () => view.setView(b.dataset.view));
$('show-path').addEventListener('change', (e) => view.showPath(e.target.checked));
$('show-fov').addEventListener('change', (e) => view.showFieldOfView(e.target.checked));

// for tests and debugging
window.scaratwin = {
  view,
  feed,
  get state() { return lastState; },
  get scene() { return sceneMsg; },
  visibleCubes: () => view.visibleCubes(),
};
