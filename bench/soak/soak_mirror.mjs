// Soak of the mirror with the browser UI open (hand-run; docs/benchmarks.md "Soak"): the
// emulated robot (our firmware in simavr, paced to real time) -> `scaratwin mirror` at
// --report-hz -> scaratwin-sim -> its page in Debian's chromium, for --minutes. The robot's jog
// buttons are pressed through the emulator's side channel every few seconds, so the arm keeps
// moving. Every --sample-s it samples the resident memory of the simulator, the hub and the
// emulator (/proc/PID/status VmRSS), of the browser's processes, and the page's JavaScript
// heap after a garbage collection; it prints one row a minute.
//
// It passes when the hub reports 0 lost frames, the page counts the same loss as the hub, and
// no process of ours, nor the page's heap, grew by more than --max-growth-mb after the first
// minute (the last minute's median against the second minute's median). The samples go to
// <out>/soak.csv, the summary to <out>/soak.json.
//
// Usage: node bench/soak/soak_mirror.mjs --bin build/release/bin
//          --node-modules build/release/web/node_modules [--minutes 30] [--report-hz 200]
//          [--sample-s 10] [--max-growth-mb 5] [--out scaratwin-out/soak] [--chromium EXE]
import { createRequire } from 'node:module';
import fs from 'node:fs';
import path from 'node:path';

import {
  check, chromiumArgs, parseArgs, results, sleep, start as startIn, startChain, stopChain,
} from '../../tests/web/harness.mjs';

const args = parseArgs(process.argv.slice(2));
const usage = 'usage: soak_mirror.mjs --bin DIR --node-modules DIR [--minutes M] [--report-hz HZ] '
  + '[--sample-s S] [--max-growth-mb MB] [--out DIR] [--chromium EXE]';
const number = (name, dflt, min, max) => {
  const v = args[name] === undefined ? dflt : Number(args[name]);
  if (!Number.isFinite(v) || v < min || v > max) {
    console.error(`soak_mirror: --${name} '${args[name]}': expected a number in [${min}, ${max}]\n${usage}`);
    process.exit(2);
  }
  return v;
};
if (!args.bin || !args['node-modules']) {
  console.error(usage);
  process.exit(2);
}
const minutes = number('minutes', 30, 0.5, 24 * 60);
const reportHz = number('report-hz', 200, 1, 1000);
const sampleS = number('sample-s', 10, 1, 600);
const maxGrowthMb = number('max-growth-mb', 5, 0, 1e6);
const out = path.resolve(args.out || 'scaratwin-out/soak');
const chromiumPath = args.chromium || '/usr/bin/chromium';
const bin = path.resolve(args.bin);
const require = createRequire(path.join(path.resolve(args['node-modules']), 'noop.js'));
const { chromium } = require('playwright-core');
const start = (exe, argv) => startIn(bin, exe, argv);

// resident memory in MB of one process, and of a process's descendants (the browser's)
const rssMb = (pid) => {
  try {
    const m = fs.readFileSync(`/proc/${pid}/status`, 'utf8').match(/VmRSS:\s+(\d+) kB/);
    return m ? Number(m[1]) / 1024 : NaN;
  } catch (e) {
    return NaN;
  }
};
const descendants = (root) => {
  const children = new Map();
  for (const e of fs.readdirSync('/proc')) {
    if (!/^\d+$/.test(e)) continue;
    try {
      // the parent is the fourth field, after the command in parentheses
      const stat = fs.readFileSync(`/proc/${e}/stat`, 'utf8');
      const ppid = Number(stat.slice(stat.lastIndexOf(')') + 2).split(' ')[1]);
      if (!children.has(ppid)) children.set(ppid, []);
      children.get(ppid).push(Number(e));
    } catch (err) { /* gone */ }
  }
  const all = [];
  const walk = (p) => { for (const c of children.get(p) || []) { all.push(c); walk(c); } };
  walk(root);
  return all;
};
const median = (xs) => {
  const s = xs.filter(Number.isFinite).sort((a, b) => a - b);
  return s.length ? s[Math.floor(s.length / 2)] : NaN;
};
const fmt = (v, d = 1) => (Number.isFinite(v) ? v.toFixed(d) : '-');

let chain = null;
let mirror = null;
let context = null;
const samples = [];
let summary = null;

try {
  fs.mkdirSync(out, { recursive: true });
  chain = await startChain(bin, {
    robotArgs: ['--camera-port', '-1', '--exit-with-parent'], db: path.join(out, 'soak.db'),
  });
  const { robot, sim, side, links, httpPort, dir } = chain;
  const home = start('scaratwin', ['home', ...links]);
  if ((await home.exited) !== 0) throw new Error(`scaratwin home failed:\n${home.output}`);

  context = await chromium.launchPersistentContext(path.join(dir, 'chromium'), {
    executablePath: chromiumPath,
    headless: true,
    args: [...chromiumArgs, '--js-flags=--expose-gc'],
  });
  const page = context.pages()[0] || await context.newPage();
  await page.goto(`http://127.0.0.1:${httpPort}/`);
  await page.waitForFunction(() => window.scaratwin && window.scaratwin.state !== null, null,
    { timeout: 20000 });
  const before = await page.evaluate(() => window.scaratwin.state.link);

  const seconds = Math.round(minutes * 60);
  mirror = start('scaratwin', ['mirror', '--seconds', String(seconds), '--report-hz', String(reportHz),
    ...links]);
  const t0 = Date.now();
  console.log(`soak: ${minutes} min of mirror at ${reportHz} Hz with the page open; `
    + `samples every ${sampleS} s (MB resident; heap: the page's JavaScript heap after a GC)`);
  console.log('| min | frames (page) | lost (page) | latency mean ms | simulator MB | hub MB | emulator MB | browser MB | page heap MB |');
  console.log('|---|---|---|---|---|---|---|---|---|');
  let press = 0;
  let nextSample = 0;
  let nextRow = 60;
  const presses = ['press j2+ 700', 'press j2- 700', 'press z- 300', 'press z+ 300'];
  while (mirror.exitCode === null) {
    const t = (Date.now() - t0) / 1000;
    if (t >= nextSample) {
      nextSample += sampleS;
      const link = await page.evaluate(() => window.scaratwin.state.link);
      const heap = await page.evaluate(() => {
        window.gc();
        return performance.memory.usedJSHeapSize / 1048576;
      });
      const browser = descendants(process.pid)
        .filter((p) => ![robot.pid, sim.pid, mirror.pid].includes(p))
        .reduce((sum, p) => sum + (rssMb(p) || 0), 0);
      samples.push({
        t_s: t, frames: link.frames - before.frames, lost: link.lost - before.lost,
        latency_mean_ms: link.latency_mean_ms, sim_mb: rssMb(sim.pid), hub_mb: rssMb(mirror.pid),
        emulator_mb: rssMb(robot.pid), browser_mb: browser, heap_mb: heap,
      });
      if (t >= nextRow) {
        nextRow += 60;
        const s = samples[samples.length - 1];
        console.log(`| ${Math.round(t / 60)} | ${s.frames} | ${s.lost} | ${fmt(s.latency_mean_ms, 2)} | `
          + `${fmt(s.sim_mb)} | ${fmt(s.hub_mb)} | ${fmt(s.emulator_mb)} | ${fmt(s.browser_mb)} | ${fmt(s.heap_mb, 2)} |`);
      }
    }
    // the operator at the robot: a jog button every 5 s, so that the arm keeps moving
    if (t >= 2 + 5 * press && t < seconds - 3) {
      await side.command(presses[press % presses.length]);
      press++;
    }
    await sleep(200);
  }
  const mirrorStatus = await mirror.exited;
  const report = mirror.output.match(/(\d+) frames mirrored, (\d+) lost/);
  await sleep(1500);  // the last frames reach the page
  const after = await page.evaluate(() => window.scaratwin.state.link);
  check('scaratwin mirror ran to its end', mirrorStatus === 0 && report !== null, mirror.output);
  const frames = report ? Number(report[1]) : 0;
  const lost = report ? Number(report[2]) : -1;
  check('the hub lost no frame', lost === 0, report ? report[0] : mirror.output);
  check('the page counts the hub\'s loss', after.lost - before.lost === lost,
    `page ${after.lost - before.lost}, hub ${lost}`);
  check(`the frames came at ${reportHz} Hz`, frames >= 0.99 * reportHz * seconds,
    `${frames} in ${seconds} s (${fmt(frames / seconds)} Hz)`);
  // growth after the first minute: the last minute's median against the second minute's
  const perMinute = Math.max(1, Math.round(60 / sampleS));
  const second = samples.filter((s) => s.t_s >= 60 && s.t_s < 120);
  const last = samples.slice(-perMinute);
  const growth = {};
  for (const k of ['sim_mb', 'hub_mb', 'emulator_mb', 'heap_mb', 'browser_mb']) {
    growth[k] = median(last.map((s) => s[k])) - median(second.map((s) => s[k]));
  }
  const judged = ['sim_mb', 'hub_mb', 'emulator_mb', 'heap_mb'];
  if (minutes >= 3) {
    for (const k of judged) {
      check(`${k.replace('_mb', '')} grew by at most ${maxGrowthMb} MB after the first minute`,
        growth[k] <= maxGrowthMb, `${fmt(growth[k], 2)} MB`);
    }
  } else {
    console.log('(under 3 minutes: memory growth is printed, not judged)');
  }
  summary = {
    minutes, report_hz: reportHz, frames, lost, page_lost: after.lost - before.lost,
    rate_hz: frames / seconds,
    latency_ms_median: median(samples.filter((s) => s.frames > 0).map((s) => s.latency_mean_ms)),
    growth_mb: growth,
    first: samples[0], last: samples[samples.length - 1],
  };
  console.log(`growth after the first minute, MB: ${Object.entries(growth).map(([k, v]) => `${k.replace('_mb', '')} ${fmt(v, 2)}`).join(', ')}`);
} catch (e) {
  check('the soak ran to its end', false, e.stack || String(e));
} finally {
  await stopChain(chain, context, mirror);
  if (samples.length) {
    const keys = Object.keys(samples[0]);
    fs.writeFileSync(path.join(out, 'soak.csv'),
      `${keys.join(',')}\n${samples.map((s) => keys.map((k) => s[k]).join(',')).join('\n')}\n`);
  }
  if (summary) fs.writeFileSync(path.join(out, 'soak.json'), `${JSON.stringify(summary, null, 2)}\n`);
  console.log(`samples: ${path.join(out, 'soak.csv')}`);
}
console.log(`${results.passed} passed, ${results.failed} failed`);
process.exit(results.failed === 0 ? 0 : 1);
