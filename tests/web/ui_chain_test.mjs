// Browser test of the web UI on the real chain: the emulated robot (our firmware in simavr,
// paced to real time) -> the hub (`scaratwin home`, then `scaratwin mirror`) -> scaratwin-sim
// -> the page in Debian's chromium. The robot's jog buttons are pressed through the emulator's
// side channel; the page's joints must end where the physical robot is (the emulator's truth,
// converted here with the description's motor constants), and the page's frame and loss
// counts must agree with what the hub's mirror reports.
//
// Usage: node ui_chain_test.mjs --bin <dir of scaratwin, scaratwin-sim, scaratwin-robot>
//        --node-modules <dir> [--chromium EXE]
// Prints one line per check and "N passed, N failed"; exits non-zero on any failure.
import { createRequire } from 'node:module';
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';

const args = Object.fromEntries(
  process.argv.slice(2).reduce((acc, v, i, a) => (v.startsWith('--') ? [...acc, [v.slice(2), a[i + 1]]] : acc), []));
const bin = args.bin;
const nodeModules = args['node-modules'];
const chromiumPath = args.chromium || '/usr/bin/chromium';
if (!bin || !nodeModules) {
  console.error('usage: ui_chain_test.mjs --bin DIR --node-modules DIR [--chromium EXE]');
  process.exit(2);
}
const require = createRequire(path.join(path.resolve(nodeModules), 'noop.js'));
const { chromium } = require('playwright-core');

// the description's motor constants (config/scara.toml), the oracle's own conversion
const kStepsPerM = 205560.0;
const kJ2StepsPerRad = 945.0;
const kJ3StepsPerRad = 1455.0;
const kCoupling = 0.8;  // J3 motor steps per J2 motor step
const deg = (rad) => (rad * 180) / Math.PI;

let passed = 0;
let failed = 0;
function check(name, ok, detail = '') {
  if (ok) passed++;
  else failed++;
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${name}${detail ? `: ${detail}` : ''}`);
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function freePort() {
  return new Promise((resolve, reject) => {
    const srv = net.createServer();
    srv.once('error', reject);
    srv.listen(0, '127.0.0.1', () => {
      const { port } = srv.address();
      srv.close(() => resolve(port));
    });
  });
}
async function waitHttp(port, timeoutMs) {
  const deadline = Date.now() + timeoutMs;
  while (Date.now() < deadline) {
    try {
      const r = await fetch(`http://127.0.0.1:${port}/api/scene`);
      if (r.ok) return true;
    } catch (e) { /* not up yet */ }
    await sleep(100);
  }
  return false;
}

function start(exe, argv) {
  const proc = spawn(path.join(bin, exe), argv, { stdio: ['ignore', 'pipe', 'pipe'] });
  proc.output = '';
  proc.stdout.on('data', (d) => { proc.output += d; });
  proc.stderr.on('data', (d) => { proc.output += d; });
  proc.exited = new Promise((resolve) => proc.on('exit', (code, signal) => resolve(code ?? -1)));
  return proc;
}
async function waitOutput(proc, re, timeoutMs) {
  const deadline = Date.now() + timeoutMs;
  while (Date.now() < deadline) {
    const m = proc.output.match(re);
    if (m) return m;
    if (proc.exitCode !== null) return null;
    await sleep(50);
  }
  return null;
}
async function stop(proc) {
  if (!proc || proc.exitCode !== null) return;
  proc.kill('SIGTERM');
  const t = setTimeout(() => proc.kill('SIGKILL'), 5000);
  await proc.exited;
  clearTimeout(t);
}

// The emulator's side channel: commands and truth samples (TR lines).
class Side {
  constructor(port) { this.port = port; this.rx = ''; }
  connect() {
    return new Promise((resolve, reject) => {
      this.sock = net.connect(this.port, '127.0.0.1', resolve);
      this.sock.once('error', reject);
      this.sock.on('data', (d) => { this.rx += d.toString('latin1'); });
    });
  }
  async line(pred, timeoutMs = 10000) {
    const deadline = Date.now() + timeoutMs;
    while (Date.now() < deadline) {
      const nl = this.rx.indexOf('\n');
      if (nl >= 0) {
        const l = this.rx.slice(0, nl);
        this.rx = this.rx.slice(nl + 1);
        if (pred(l)) return l;
        continue;
      }
      await sleep(10);
    }
    return null;
  }
  async command(cmd) {
    this.sock.write(`${cmd}\n`);
    return this.line((l) => !l.startsWith('TR '));
  }
  async truth() {
    this.sock.write('query\n');
    const l = await this.line((l) => l.startsWith('TR '));
    return Object.fromEntries(l.split(' ').slice(1).map((kv) => kv.split('=')));
  }
  close() { if (this.sock) this.sock.destroy(); }
}

const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'scaratwin-chain-'));
const pty = path.join(dir, 'robot.pty');
let robot = null;
let sim = null;
let mirror = null;
let context = null;
let side = null;

try {
  const httpPort = await freePort();
  robot = start('scaratwin-robot', ['--plant', 'ideal', '--pty-link', pty]);
  sim = start('scaratwin-sim', ['--port', '0', '--http-port', String(httpPort), '--no-camera']);
  const sideLine = await waitOutput(robot, /side channel: 127\.0\.0\.1:(\d+)/, 30000);
  const simLine = await waitOutput(sim, /listening on 127\.0\.0\.1:(\d+)/, 30000);
  const httpUp = await waitHttp(httpPort, 30000);
  check('the robot, the simulator and its page are up', sideLine && simLine && httpUp,
    `${robot.output} ${sim.output}`);
  if (!sideLine || !simLine || !httpUp) throw new Error('not up');
  const links = ['--serial', pty, '--sim', `127.0.0.1:${simLine[1]}`, '--no-db'];
  side = new Side(Number(sideLine[1]));
  await side.connect();
  await side.command('rate 0');

  // the counts are the joints' only once homed
  const home = start('scaratwin', ['home', ...links]);
  const homeStatus = await home.exited;
  check('scaratwin home', homeStatus === 0, home.output);

  context = await chromium.launchPersistentContext(path.join(dir, 'chromium'), {
    executablePath: chromiumPath,
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  const page = context.pages()[0] || await context.newPage();
  await page.goto(`http://127.0.0.1:${httpPort}/`);
  await page.waitForFunction(() => window.scaratwin && window.scaratwin.state !== null, null, { timeout: 20000 });
  const framesBefore = await page.evaluate(() => window.scaratwin.state.link.frames);
  const lostBefore = await page.evaluate(() => window.scaratwin.state.link.lost);

  // mirror while the operator presses J2+ and then Z- at the robot
  mirror = start('scaratwin', ['mirror', '--seconds', '8', ...links]);
  await sleep(1500);
  check('J2+ pressed', (await side.command('press j2+ 700')) === 'OK press j2+ 700');
  await sleep(1500);
  check('Z- pressed', (await side.command('press z- 500')) === 'OK press z- 500');
  const mirrorStatus = await mirror.exited;
  const report = mirror.output.match(/(\d+) frames mirrored, (\d+) lost/);
  check('scaratwin mirror', mirrorStatus === 0 && report !== null, mirror.output);

  // where the physical robot is, converted from its true motor steps
  const t = await side.truth();
  const z = Number(t.z), j2 = Number(t.j2), j3 = Number(t.j3);
  const want = [(z / kStepsPerM) * 1000, deg(j2 / kJ2StepsPerRad), deg((j3 - kCoupling * j2) / kJ3StepsPerRad)];
  check('the robot moved', Math.abs(want[1]) > 10 && Math.abs(want[0] - 120) > 1, JSON.stringify(want));
  await sleep(500);
  const shown = (await page.locator('.joint .value').allTextContents()).map(Number);
  check('the page shows the physical robot\'s d1, q2, q3',
    Math.abs(shown[0] - want[0]) <= 0.06 && Math.abs(shown[1] - want[1]) <= 0.06 && Math.abs(shown[2] - want[2]) <= 0.06,
    `page ${shown.slice(0, 3).join(' ')}, truth ${want.map((v) => v.toFixed(3)).join(' ')}`);
  if (report) {
    const link = await page.evaluate(() => window.scaratwin.state.link);
    // the hub's count covers its --seconds; the page also sees the few frames forwarded while
    // the hub closes (1 s at 100 Hz at most)
    const extra = link.frames - framesBefore - Number(report[1]);
    check('the page counts the frames the hub mirrored', extra >= 0 && extra <= 100,
      `page ${link.frames - framesBefore}, hub ${report[1]}`);
    check('the page counts the frames the hub lost', link.lost - lostBefore === Number(report[2]),
      `page ${link.lost - lostBefore}, hub ${report[2]}`);
  }
} catch (e) {
  check('test ran to the end', false, e.stack || String(e));
} finally {
  if (side) side.close();
  if (context) await context.close().catch(() => {});
  await stop(mirror);
  await stop(sim);
  await stop(robot);
  fs.rmSync(dir, { recursive: true, force: true });
}
console.log(`${passed} passed, ${failed} failed`);
process.exit(failed === 0 ? 0 : 1);
