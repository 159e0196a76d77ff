// The fleet page: every robot whose hub publishes on the broker the simulator watches
// (scaratwin-sim --mqtt URL). Polls /api/fleet (the simulator's fleet::FleetWatcher) a few
// times a second and draws one row per robot; a robot silent for 2 s is shown stale.
const token = new URLSearchParams(location.search).get('token');
const q = token ? `?token=${encodeURIComponent(token)}` : '';
const STALE_MS = 2000;
const $ = (id) => document.getElementById(id);
if (token) $('to-robot').href = `index.html${q}`;

const fmt = (v, digits) => (typeof v === 'number' && Number.isFinite(v) ? v.toFixed(digits) : '—');
const esc = (s) => String(s).replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`);

function cells(r) {
  const s = r.state;
  const conn = r.connection ?? '—';
  const connClass = conn === 'online' ? 'ok' : conn === 'offline' ? 'bad' : 'dim';
  const stale = r.age_ms === null || r.age_ms > STALE_MS;
  if (!s) {
    return [esc(r.name), `<b class="${connClass}">${esc(conn)}</b>`, '—', '—', '—', '—', '—', '—',
      '—', '—', '—'];
  }
  const j = s.joints;
  const t = s.tool;
  const joints = j ? `${fmt(j.d1_m * 1000, 1)} · ${fmt(j.q2_deg, 1)} · ${fmt(j.q3_deg, 1)} · ${fmt(j.q4_deg, 1)}` : '—';
  const tool = t ? `${fmt(t.x_m * 1000, 1)} · ${fmt(t.y_m * 1000, 1)} · ${fmt(t.z_m * 1000, 1)}` : '—';
  const link = s.link ?? {};
  const links = `<b class="${link.robot ? 'ok' : 'bad'}">robot</b> <b class="${link.sim ? 'ok' : 'bad'}">sim</b>`;
  const m = s.mirror ?? {};
  const lat = `${fmt(m.latency_ms, 2)} / ${fmt(m.mean_latency_ms, 2)} ms`;
  const frames = `${m.frames ?? '—'} / <b class="${m.lost ? 'warn' : ''}">${m.lost ?? '—'}</b>`;
  const a = s.alarms ?? {};
  const alarms = [a.desync ? `desync ${a.desync}` : '', a.halted ? 'halted' : '',
    a.interrupted ? 'interrupted' : ''].filter(Boolean).join(', ') || 'none';
  const job = s.job ?? {};
  const jobText = job.statement
    ? `${job.running ? '▶ ' : ''}${esc(job.statement)} <small>(${job.done ?? 0} ok, ${job.failed ?? 0} failed${job.queued ? `, ${job.queued} waiting` : ''})</small>`
    : '—';
  const age = r.age_ms === null ? '—' : `<b class="${stale ? 'warn' : ''}">${fmt(r.age_ms / 1000, 1)} s</b>`;
  return [esc(r.name), `<b class="${connClass}">${esc(conn)}</b>`, esc(s.mode ?? '—'), joints, tool, links, lat,
    frames, `<span class="${alarms === 'none' ? 'dim' : 'bad'}">${esc(alarms)}</span>`, jobText, age];
}

function draw(fleet) {
  $('broker').textContent = `broker ${fleet.broker}`;
  const online = fleet.robots.filter((r) => r.connection === 'online').length;
  $('counts').textContent = `${online} online / ${fleet.robots.length} robots`;
  const pill = $('conn');
  pill.className = `pill ${fleet.connected ? 'live' : 'down'}`;
  pill.querySelector('b').textContent = fleet.connected ? 'broker connected' : 'broker unreachable';
  const rows = $('rows');
  if (fleet.robots.length === 0) {
    rows.innerHTML = '<tr class="empty"><td colspan="11">no robot on the broker yet</td></tr>';
    return;
  }
  rows.innerHTML = fleet.robots.map((r) => {
    const stale = r.age_ms === null || r.age_ms > STALE_MS;
    return `<tr data-robot="${esc(r.name)}" class="${r.connection === 'online' && !stale ? 'live' : 'stale'}">` +
      cells(r).map((c) => `<td>${c}</td>`).join('') + '</tr>';
  }).join('');
}

async function poll() {
  try {
    const res = await fetch(`/api/fleet${q}`, { cache: 'no-store' });
    if (!res.ok) {
      $('note').textContent = (await res.text()).trim();
      $('conn').className = 'pill down';
      $('conn').querySelector('b').textContent = res.status === 404 ? 'no fleet' : `HTTP ${res.status}`;
    } else {
      $('note').textContent = '';
      draw(await res.json());
    }
  } catch (e) {
    $('conn').className = 'pill down';
    $('conn').querySelector('b').textContent = 'simulator unreachable';
  }
  setTimeout(poll, 250);
}
poll();
