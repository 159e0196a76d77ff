// What the browser tests on real processes share: checks that count, free ports, child
// processes with their output, and the emulated robot's side channel (commands and truth).
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

export function parseArgs(argv) {
  return Object.fromEntries(
    argv.reduce((acc, v, i, a) => (v.startsWith('--') ? [...acc, [v.slice(2), a[i + 1]]] : acc), []));
}

export const results = { passed: 0, failed: 0 };
export function check(name, ok, detail = '') {
  if (ok) results.passed++;
  else results.failed++;
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${name}${detail ? `: ${detail}` : ''}`);
}

export async function freePort() {
  return new Promise((resolve, reject) => {
    const srv = net.createServer();
    srv.once('error', reject);
    srv.listen(0, '127.0.0.1', () => {
      const { port } = srv.address();
      srv.close(() => resolve(port));
    });
  });
}

export async function waitHttp(port, timeoutMs) {
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

// `exe` is a path, or a name in `bin`
export function start(bin, exe, argv) {
  const proc = spawn(path.isAbsolute(exe) ? exe : path.join(bin, exe), argv,
    { stdio: ['ignore', 'pipe', 'pipe'] });
  proc.output = '';
  proc.stdout.on('data', (d) => { proc.output += d; });
  proc.stderr.on('data', (d) => { proc.output += d; });
  proc.exited = new Promise((resolve) => proc.on('exit', (code, signal) => resolve(code ?? -1)));
  return proc;
}

export async function waitOutput(proc, re, timeoutMs) {
  const deadline = Date.now() + timeoutMs;
  while (Date.now() < deadline) {
    const m = proc.output.match(re);
    if (m) return m;
    if (proc.exitCode !== null) return null;
    await sleep(50);
  }
  return null;
}

export async function stop(proc, signal = 'SIGTERM') {
  if (!proc || proc.exitCode !== null) return;
  proc.kill(signal);
  const t = setTimeout(() => proc.kill('SIGKILL'), 5000);
  await proc.exited;
  clearTimeout(t);
}

// The emulator's side channel: commands and truth samples (TR lines).
export class Side {
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

// the description's motor constants (config/scara.toml): the oracle's own conversion of the
// emulator's true motor steps to joints (d1 mm, q2 deg, q3 deg)
export const kStepsPerM = 205560.0;
export const kJ2StepsPerRad = 945.0;
export const kJ3StepsPerRad = 1455.0;
export const kCoupling = 0.8;  // J3 motor steps per J2 motor step
const deg = (rad) => (rad * 180) / Math.PI;
export function jointsOfSteps(z, j2, j3) {
  return [(z / kStepsPerM) * 1000, deg(j2 / kJ2StepsPerRad), deg((j3 - kCoupling * j2) / kJ3StepsPerRad)];
}

export const chromiumArgs = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic',
  '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync'];

// The real chain without its hub: the emulated robot (`robotArgs` added to its command line)
// and the simulator serving its page on a free port, in a fresh temporary directory; the
// robot's side channel connected (its truth samples off: `rate 0`). `links` are the options
// that point a hub at both, recording into `db` (or nothing). Throws when something does not
// come up; stopChain() ends what was started.
export async function startChain(bin, { robotArgs = [], db = null } = {}) {
  const chain = { dir: fs.mkdtempSync(path.join(os.tmpdir(), 'scaratwin-chain-')), procs: [] };
  const pty = path.join(chain.dir, 'robot.pty');
  chain.httpPort = await freePort();
  chain.robot = start(bin, 'scaratwin-robot', ['--pty-link', pty, ...robotArgs]);
  chain.sim = start(bin, 'scaratwin-sim', ['--port', '0', '--http-port', String(chain.httpPort), '--no-camera']);
  chain.procs.push(chain.robot, chain.sim);
  try {
    await connectChain(chain, db);
  } catch (e) {
    await stopChain(chain);
    throw e;
  }
  return chain;
}

async function connectChain(chain, db) {
  const sideLine = await waitOutput(chain.robot, /side channel: 127\.0\.0\.1:(\d+)/, 30000);
  const simLine = await waitOutput(chain.sim, /listening on 127\.0\.0\.1:(\d+)/, 30000);
  const httpUp = await waitHttp(chain.httpPort, 30000);
  if (!sideLine || !simLine || !httpUp) {
    throw new Error(`the robot, the simulator or its page did not come up:\n${chain.robot.output}\n${chain.sim.output}`);
  }
  const pty = path.join(chain.dir, 'robot.pty');
  chain.links = ['--serial', pty, '--sim', `127.0.0.1:${simLine[1]}`, ...(db ? ['--db', db] : ['--no-db'])];
  chain.side = new Side(Number(sideLine[1]));
  await chain.side.connect();
  await chain.side.command('rate 0');
}

// Ends the browser `context` (if any), the processes in `more` (a hub), then the chain.
export async function stopChain(chain, context, ...more) {
  if (chain && chain.side) chain.side.close();
  if (context) await context.close().catch(() => {});
  for (const p of more) await stop(p);
  if (!chain) return;
  for (const p of chain.procs) await stop(p);
  fs.rmSync(chain.dir, { recursive: true, force: true });
}
