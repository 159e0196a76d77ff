// Small strip charts on a canvas: time on x (the last `spanS` seconds), one or more series.
// No chart library: a few dozen lines draw exactly what the twin needs.

export class History {
  constructor(spanS = 10) {
    this.spanS = spanS;
    this.samples = [];
  }
  push(sample) {
    this.samples.push(sample);
    const cut = sample.t - this.spanS - 1;
    while (this.samples.length && this.samples[0].t < cut) this.samples.shift();
  }
}

function fit(canvas) {
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(1, Math.round(canvas.clientWidth * dpr));
  const h = Math.max(1, Math.round(canvas.clientHeight * dpr));
  if (canvas.width !== w || canvas.height !== h) {
    canvas.width = w;
    canvas.height = h;
  }
  const ctx = canvas.getContext('2d');
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  return { ctx, w: w / dpr, h: h / dpr };
}

function niceRange(lo, hi, minSpan) {
  if (!isFinite(lo) || !isFinite(hi)) return [0, 1];
  if (hi - lo < minSpan) {
    const mid = (hi + lo) / 2;
    lo = mid - minSpan / 2;
    hi = mid + minSpan / 2;
  }
  const pad = (hi - lo) * 0.12;
  return [lo - pad, hi + pad];
}

const fmt = (v) => (Math.abs(v) >= 100 ? v.toFixed(0) : Math.abs(v) >= 10 ? v.toFixed(1) : v.toFixed(2));

// Draws one panel: box at (x, y, w, h), series [{get(sample) -> number|null, color, dash}].
function panel(ctx, box, history, now, series, opts) {
  const { x, y, w, h } = box;
  const t0 = now - history.spanS;
  let lo = Infinity;
  let hi = -Infinity;
  for (const s of history.samples) {
    if (s.t < t0) continue;
    for (const ser of series) {
      const v = ser.get(s);
      if (v === null || v === undefined) continue;
      lo = Math.min(lo, v);
      hi = Math.max(hi, v);
    }
  }
  if (opts.zero) lo = Math.min(lo, 0);
  [lo, hi] = niceRange(lo, hi, opts.minSpan);
  if (opts.zero) lo = Math.max(lo, 0);
  const px = (t) => x + ((t - t0) / history.spanS) * w;
  const py = (v) => y + h - ((v - lo) / (hi - lo)) * h;

  ctx.fillStyle = '#131821';
  ctx.fillRect(x, y, w, h);
  ctx.strokeStyle = '#222b3a';
  ctx.lineWidth = 1;
  ctx.beginPath();
  for (let k = 1; k < 4; k++) {
    const gy = Math.round(y + (h * k) / 4) + 0.5;
    ctx.moveTo(x, gy);
    ctx.lineTo(x + w, gy);
  }
  for (let k = 1; k < 10; k++) {
    const gx = Math.round(x + (w * k) / 10) + 0.5;
    ctx.moveTo(gx, y);
    ctx.lineTo(gx, y + h);
  }
  ctx.stroke();

  for (const ser of series) {
    ctx.strokeStyle = ser.color;
    ctx.lineWidth = ser.width || 1.6;
    ctx.setLineDash(ser.dash ? [5, 4] : []);
    ctx.beginPath();
    let pen = false;
    for (const s of history.samples) {
      if (s.t < t0 - 0.5) continue;
      const v = ser.get(s);
      if (v === null || v === undefined) {
        pen = false;
        continue;
      }
      if (pen) ctx.lineTo(px(s.t), py(v));
      else ctx.moveTo(px(s.t), py(v));
      pen = true;
    }
    ctx.stroke();
  }
  ctx.setLineDash([]);

  ctx.font = '10px ui-monospace, DejaVu Sans Mono, monospace';
  ctx.fillStyle = '#8593a8';
  ctx.textBaseline = 'top';
  ctx.fillText(fmt(hi), x + 3, y + 2);
  ctx.textBaseline = 'bottom';
  ctx.fillText(fmt(lo), x + 3, y + h - 1);
  if (opts.label) {
    ctx.font = '600 11px ui-monospace, DejaVu Sans Mono, monospace';
    ctx.fillStyle = opts.labelColor || '#d9e1ec';
    ctx.textBaseline = 'top';
    ctx.textAlign = 'right';
    ctx.fillText(opts.label, x + w - 4, y + 3);
    ctx.textAlign = 'left';
  }
  ctx.strokeStyle = '#2b3547';
  ctx.strokeRect(x + 0.5, y + 0.5, w - 1, h - 1);
}

const JOINT_COLORS = ['#4fb3ff', '#f5b841', '#c792ea', '#3ecf8e'];

// Four small panels side by side: d1, q2, q3, q4, virtual solid and physical dashed.
export function drawJoints(canvas, history, now, joints) {
  const { ctx, w, h } = fit(canvas);
  ctx.clearRect(0, 0, w, h);
  const gap = 8;
  const pw = (w - gap * 3) / 4;
  for (let j = 0; j < 4; j++) {
    const name = joints ? `${joints[j].name} ${joints[j].unit}` : `j${j + 1}`;
    panel(ctx, { x: j * (pw + gap), y: 0, w: pw, h }, history, now, [
      { get: (s) => (s.physical ? s.physical[j] : null), color: '#e6edf7', dash: true, width: 1.2 },
      { get: (s) => s.virtual[j], color: JOINT_COLORS[j], width: 1.8 },
    ], { minSpan: j === 0 ? 2 : 2, label: name, labelColor: JOINT_COLORS[j] });
  }
}

export function drawLatency(canvas, history, now) {
  const { ctx, w, h } = fit(canvas);
  ctx.clearRect(0, 0, w, h);
  panel(ctx, { x: 0, y: 0, w, h }, history, now, [
    { get: (s) => s.latency, color: '#3ecf8e', width: 1.6 },
    { get: (s) => s.latencyMax, color: '#f5b841', width: 1, dash: true },
  ], { minSpan: 1, zero: true, label: 'latency · max' });
  // lost frames as red ticks along the bottom
  const t0 = now - history.spanS;
  let prev = null;
  ctx.fillStyle = '#ff5d5d';
  for (const s of history.samples) {
    if (prev !== null && s.lost > prev && s.t >= t0) {
      const x = ((s.t - t0) / history.spanS) * w;
      ctx.fillRect(x - 1, h - 10, 2, 9);
    }
    prev = s.lost;
  }
}
