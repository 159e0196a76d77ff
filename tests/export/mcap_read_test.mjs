// `scaratwin export RUN --mcap FILE` read by the MCAP project's own reader (@mcap/core, zstd by
// fzstd): a twin database recorded through TwinDb (make_run_db), exported by the real command,
// then every topic's count and the joint values held against the database read with the
// sqlite3 command line, the Foxglove messages held to Foxglove's own JSON schemas
// (@foxglove/schemas); and a copy cut in the middle of the data still streams up to its last
// whole chunk.
//
// Usage: node mcap_read_test.mjs --bin DIR --fixture EXE --node-modules DIR --work DIR
//        [--sqlite3 EXE]
// Prints one line per check and "N passed, N failed"; exits non-zero on any failure.
import { createRequire } from 'node:module';
import { execFileSync, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';

import { check, parseArgs, results } from '../web/harness.mjs';

const args = parseArgs(process.argv.slice(2));
if (!args.bin || !args.fixture || !args['node-modules'] || !args.work) {
  console.error('usage: mcap_read_test.mjs --bin DIR --fixture EXE --node-modules DIR --work DIR');
  process.exit(2);
}
const require = createRequire(path.join(path.resolve(args['node-modules']), 'noop.js'));
const { McapIndexedReader, McapStreamReader } = require('@mcap/core');
const fzstd = require('fzstd');
const foxglove = require('@foxglove/schemas/jsonschema');
const decompressHandlers = { zstd: (data, size) => fzstd.decompress(data, new Uint8Array(Number(size))) };

fs.mkdirSync(args.work, { recursive: true });
const db = path.join(args.work, 'twin.db');
const out = path.join(args.work, 'run.mcap');
fs.rmSync(out, { force: true });
execFileSync(args.fixture, [db], { stdio: 'inherit' });

// --- the database, read with sqlite3 itself ------------------------------------------------------
const sql = (q) =>
  JSON.parse(execFileSync(args.sqlite3 || 'sqlite3', ['-json', db, q], { encoding: 'utf8' }) || '[]');
const top = sql('SELECT MAX(id) AS id FROM runs WHERE parent = 0')[0].id;
const runIds = sql(`SELECT id FROM runs WHERE id = ${top} OR parent = ${top}`).map((r) => r.id);
const inRuns = `run IN (${runIds.join(',')})`;
const count = (table, where = '') =>
  sql(`SELECT COUNT(*) AS n FROM ${table} WHERE ${inRuns} ${where}`)[0].n;
const expected = {
  '/planned/joints': count('samples', "AND source = 'planned'"),
  '/virtual/joints': count('samples', "AND source = 'virtual'"),
  '/physical/joints': count('samples', "AND source = 'physical'"),
  '/truth/joints': count('samples', "AND source = 'truth'"),
  '/physical/tf': count('samples', "AND source = 'physical'"),
  '/virtual/tf': count('samples', "AND source = 'virtual'"),
  '/events': count('events'),
  '/camera': count('images'),
  '/mirror/latency': count('latencies'),
  '/commands': count('commands'),
};
const schemaOf = {
  '/planned/joints': 'scaratwin.JointSample',
  '/virtual/joints': 'scaratwin.JointSample',
  '/physical/joints': 'scaratwin.JointSample',
  '/truth/joints': 'scaratwin.JointSample',
  '/physical/tf': 'foxglove.FrameTransforms',
  '/virtual/tf': 'foxglove.FrameTransforms',
  '/events': 'foxglove.Log',
  '/camera': 'foxglove.CompressedImage',
  '/mirror/latency': 'scaratwin.MirrorLatency',
  '/commands': 'scaratwin.Command',
};

// --- the command ---------------------------------------------------------------------------------
const scaratwin = path.join(args.bin, 'scaratwin');
const t0 = process.hrtime.bigint();
const run = spawnSync(scaratwin, ['export', 'latest', '--db', db, '--mcap', out], { encoding: 'utf8' });
const ms = Number(process.hrtime.bigint() - t0) / 1e6;
check('scaratwin export latest --mcap exits 0', run.status === 0, run.stderr.trim());
process.stdout.write(run.stdout);
console.log(`(export took ${ms.toFixed(0)} ms, ${fs.statSync(out).size} bytes)`);
const bad = spawnSync(scaratwin, ['export', '9999', '--db', db, '--mcap', `${out}.x`], { encoding: 'utf8' });
check('an unknown run exits 2 and names it', bad.status === 2 && /no run 9999/.test(bad.stderr),
  `${bad.status} ${bad.stderr.trim()}`);
const word = spawnSync(scaratwin, ['export', 'newest', '--db', db, '--mcap', `${out}.x`], { encoding: 'utf8' });
check('a RUN that is neither an id nor latest exits 2', word.status === 2 && /'newest'/.test(word.stderr),
  `${word.status} ${word.stderr.trim()}`);
const nowhere = path.join(args.work, 'no-such-folder', 'run.mcap');
const unwritable = spawnSync(scaratwin, ['export', 'latest', '--db', db, '--mcap', nowhere], { encoding: 'utf8' });
check('a file that cannot be written exits 1 and names it',
  unwritable.status === 1 && unwritable.stderr.includes(`cannot write '${nowhere}'`),
  `${unwritable.status} ${unwritable.stderr.trim()}`);

// --- the indexed reader --------------------------------------------------------------------------
const bytes = new Uint8Array(fs.readFileSync(out));
const readable = {
  size: async () => BigInt(bytes.length),
  read: async (offset, length) => bytes.subarray(Number(offset), Number(offset + length)),
};
const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
const topicOf = new Map([...reader.channelsById].map(([id, c]) => [id, c.topic]));
const topics = [...reader.channelsById.values()].map((c) => c.topic).sort();
check('one channel per topic that has rows', JSON.stringify(topics) ===
  JSON.stringify(Object.keys(expected).filter((t) => expected[t] > 0).sort()), topics.join(' '));
for (const c of reader.channelsById.values()) {
  const s = reader.schemasById.get(c.schemaId);
  check(`${c.topic}: schema ${schemaOf[c.topic]}, jsonschema, json`,
    s && s.name === schemaOf[c.topic] && s.encoding === 'jsonschema' && c.messageEncoding === 'json' &&
    JSON.parse(new TextDecoder().decode(s.data)).title === s.name, s && s.name);
}
check('several chunks', reader.chunkIndexes.length >= 3, `${reader.chunkIndexes.length}`);

const byTopic = new Map();
for await (const m of reader.readMessages()) {
  const t = topicOf.get(m.channelId);
  if (!byTopic.has(t)) byTopic.set(t, []);
  byTopic.get(t).push(m);
}
for (const [t, n] of Object.entries(expected)) {
  const got = (byTopic.get(t) || []).length;
  check(`${t}: ${n} messages, as the database's rows`, got === n && n > 0, `${got}`);
  const stat = [...reader.channelsById].find(([, c]) => c.topic === t);
  if (stat) {
    check(`${t}: the statistics count it`, reader.statistics.channelMessageCounts.get(stat[0]) === BigInt(n));
  }
}

// the joint values, exactly (printf %!.17g keeps every bit of a double)
const decode = (m) => JSON.parse(new TextDecoder().decode(m.data));
const startNs = new Map(sql(`SELECT id, printf('%!.17g', started_unix_s) AS s FROM runs WHERE ${inRuns.replace('run', 'id')}`)
  .map((r) => [r.id, Number(r.s)]));
for (const source of ['planned', 'virtual', 'physical', 'truth']) {
  const rows = sql(`SELECT run, printf('%!.17g', t_s) AS t_s, seq, printf('%!.17g', d1_m) AS d1_m,
      printf('%!.17g', q2_rad) AS q2_rad, printf('%!.17g', q3_rad) AS q3_rad,
      printf('%!.17g', q4_rad) AS q4_rad, printf('%!.17g', grip_deg) AS grip_deg
      FROM samples WHERE ${inRuns} AND source = '${source}' ORDER BY run, t_s, rowid`);
  const msgs = (byTopic.get(`/${source}/joints`) || []).map((m) => ({ m, j: decode(m) }));
  msgs.sort((a, b) => a.j.run - b.j.run || a.j.t_s - b.j.t_s);
  let same = rows.length === msgs.length;
  let times = true;
  for (let i = 0; same && i < rows.length; ++i) {
    const r = rows[i];
    const { m, j } = msgs[i];
    same = j.run === r.run && j.t_s === Number(r.t_s) && j.seq === r.seq &&
      j.d1_m === Number(r.d1_m) && j.q2_rad === Number(r.q2_rad) && j.q3_rad === Number(r.q3_rad) &&
      j.q4_rad === Number(r.q4_rad) && j.grip_deg === Number(r.grip_deg);
    // log time: ns since the Unix epoch, the run's start plus t_s (to a microsecond)
    const want = (startNs.get(r.run) + Number(r.t_s)) * 1e9;
    times = times && Math.abs(Number(m.logTime) - want) < 1e3;
    if (!same) console.log('  differs:', JSON.stringify(r), JSON.stringify(j));
  }
  check(`/${source}/joints: the database's values, every bit`, same && rows.length > 0);
  check(`/${source}/joints: log time = run start + t_s`, times);
}

// the frames: the tool of the physical robot where the description's FK puts it
{
  const m = byTopic.get('/physical/tf')[0];
  const tf = decode(m).transforms;
  const names = tf.map((x) => `${x.parent_frame_id}>${x.child_frame_id}`).join(' ');
  check('a frame message links world to the tool', names ===
    'world>physical/base_link physical/base_link>physical/carriage physical/carriage>physical/link1 ' +
    'physical/link1>physical/link2 physical/link2>physical/wrist physical/wrist>physical/tool', names);
  // the frames composed (quaternions and translations) against the paper's FK of the joints
  const mul = (a, b) => ({
    w: a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
    x: a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
    y: a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
    z: a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
  });
  const rotate = (q, v) => {
    const r = mul(mul(q, { w: 0, ...v }), { w: q.w, x: -q.x, y: -q.y, z: -q.z });
    return { x: r.x, y: r.y, z: r.z };
  };
  let worst = 0;
  const joints = new Map(byTopic.get('/physical/joints').map((j) => [j.logTime, decode(j)]));
  for (const f of byTopic.get('/physical/tf')) {
    let q = { w: 1, x: 0, y: 0, z: 0 };
    let p = { x: 0, y: 0, z: 0 };
    for (const x of decode(f).transforms) {
      const t = rotate(q, x.translation);
      p = { x: p.x + t.x, y: p.y + t.y, z: p.z + t.z };
      q = mul(q, x.rotation);
    }
    const j = joints.get(f.logTime);
    const want = {
      x: 0.067 + 0.092 * Math.cos(j.q2_rad) + 0.095 * Math.cos(j.q2_rad + j.q3_rad),
      y: 0.092 * Math.sin(j.q2_rad) + 0.095 * Math.sin(j.q2_rad + j.q3_rad),
      z: j.d1_m - 0.067,
    };
    worst = Math.max(worst, Math.abs(p.x - want.x), Math.abs(p.y - want.y), Math.abs(p.z - want.z));
  }
  check('each physical tool frame is where the paper\'s FK puts the tool (1e-9 m)', worst < 1e-9,
    `${worst}`);
  const ts = tf[0].timestamp;
  check('a frame carries its log time', BigInt(ts.sec) * 1000000000n + BigInt(ts.nsec) === m.logTime);
}

// the image's bytes, and the events' levels
{
  const png = sql(`SELECT hex(png) AS h FROM images WHERE ${inRuns}`)[0].h;
  const img = decode(byTopic.get('/camera')[0]);
  check('the image is the database\'s PNG', img.format === 'png' &&
    Buffer.from(img.data, 'base64').toString('hex').toUpperCase() === png);
  const logs = byTopic.get('/events').map(decode);
  const desync = logs.find((l) => l.name === 'desync');
  check('a desync event is a WARNING log with its detail', desync && desync.level === 3 &&
    desync.message === 'tool 3.2 mm off the plan, "quoted"');
}

// the Foxglove messages against Foxglove's own JSON schemas (@foxglove/schemas): the keywords
// those schemas use (type, properties, required, items, oneOf/const, minimum, maximum)
function conforms(schema, v, where = '$') {
  if (schema.oneOf) {
    return schema.oneOf.some((s) => !conforms(s, v, where)) ? '' : `${where}: none of oneOf`;
  }
  if ('const' in schema && v !== schema.const) return `${where}: not ${schema.const}`;
  const types = { object: (x) => x !== null && typeof x === 'object' && !Array.isArray(x),
    array: Array.isArray, string: (x) => typeof x === 'string', number: (x) => typeof x === 'number',
    integer: Number.isInteger, boolean: (x) => typeof x === 'boolean', null: (x) => x === null };
  if (schema.type && ![schema.type].flat().some((t) => types[t](v))) return `${where}: not ${schema.type}`;
  if (schema.minimum !== undefined && v < schema.minimum) return `${where}: below ${schema.minimum}`;
  if (schema.maximum !== undefined && v > schema.maximum) return `${where}: above ${schema.maximum}`;
  for (const r of schema.required || []) if (!(r in v)) return `${where}.${r}: missing`;
  for (const [k, sub] of Object.entries(schema.properties || {})) {
    if (v && k in v) {
      const e = conforms(sub, v[k], `${where}.${k}`);
      if (e) return e;
    }
  }
  if (schema.items) {
    for (let i = 0; i < v.length; ++i) {
      const e = conforms(schema.items, v[i], `${where}[${i}]`);
      if (e) return e;
    }
  }
  return '';
}
for (const [topic, name] of [['/physical/tf', 'FrameTransforms'], ['/virtual/tf', 'FrameTransforms'],
  ['/events', 'Log'], ['/camera', 'CompressedImage']]) {
  let error = '';
  for (const m of byTopic.get(topic)) {
    error = conforms(foxglove[name], decode(m));
    if (error) break;
  }
  check(`${topic}: every message conforms to Foxglove's ${foxglove[name].title}`, !error, error);
  // and the schema the file carries has Foxglove's fields and types
  const shape = (x) => x.oneOf ? x.oneOf.map((o) => o.const) : x.items ? [shape(x.items)] :
    x.properties ? Object.fromEntries(Object.entries(x.properties).map(([k, v]) => [k, shape(v)]))
      : x.type;
  const c = [...reader.channelsById.values()].find((ch) => ch.topic === topic);
  const ours = JSON.parse(new TextDecoder().decode(reader.schemasById.get(c.schemaId).data));
  const sorted = (x) => JSON.stringify(x, (k, v) =>
    v && typeof v === 'object' && !Array.isArray(v) ? Object.fromEntries(Object.entries(v).sort()) : v);
  const same = sorted(shape(ours)) === sorted(shape(foxglove[name]));
  check(`${topic}: its schema has the fields and types of Foxglove's`, same,
    same ? '' : `${sorted(shape(ours))} against ${sorted(shape(foxglove[name]))}`);
}

// metadata and attachments
{
  const meta = [];
  for await (const r of reader.readMetadata()) meta.push(r);
  const runs = meta.filter((r) => r.name === 'scaratwin.run').map((r) => Number(r.metadata.get('id')));
  check('a scaratwin.run metadata record per run', JSON.stringify(runs.sort()) ===
    JSON.stringify([...runIds].sort()), runs.join(','));
  const robot = meta.find((r) => r.name === 'scaratwin.robot');
  check('the robot description\'s hash in the metadata', robot &&
    /^[0-9a-f]{8}$/.test(robot.metadata.get('description_hash')));
  const names = [];
  for await (const a of reader.readAttachments()) names.push(a.name);
  check('the description and its URDF attached', names.includes('scara.toml') &&
    names.some((n) => n.endsWith('.urdf')), names.join(' '));
}

// --- streaming: in file order, log times never go back; a cut copy reads to its last whole chunk
function stream(data) {
  const s = new McapStreamReader({ includeChunks: true, decompressHandlers });
  s.append(data);
  const msgs = [];
  let chunks = 0;
  for (let r; (r = s.nextRecord()); ) {
    if (r.type === 'Chunk') chunks++;
    if (r.type === 'Message') msgs.push({ chunk: chunks, logTime: r.logTime, channelId: r.channelId });
  }
  return { msgs, done: s.done() };
}
const full = stream(bytes);
const total = Object.values(expected).reduce((a, b) => a + b, 0);
check('the stream reader reads every message', full.msgs.length === total && full.done,
  `${full.msgs.length} of ${total}`);
check('log times in file order never go back',
  full.msgs.every((m, i) => i === 0 || m.logTime >= full.msgs[i - 1].logTime));
// cut inside the third chunk's records: the first two chunks stay whole
const third = reader.chunkIndexes[2];
const cut = Number(third.chunkStartOffset) + Math.floor(Number(third.chunkLength) / 2);
fs.writeFileSync(`${out}.cut`, bytes.subarray(0, cut));
const part = stream(new Uint8Array(fs.readFileSync(`${out}.cut`)));
const whole = full.msgs.filter((m) => m.chunk <= 2);
check('a copy cut in its third chunk reads the first two chunks\' messages',
  part.msgs.length === whole.length && !part.done &&
  part.msgs.every((m, i) => m.logTime === whole[i].logTime && m.channelId === whole[i].channelId),
  `${part.msgs.length} of ${whole.length}`);

console.log(`${results.passed} passed, ${results.failed} failed`);
process.exit(results.failed === 0 ? 0 : 1);
