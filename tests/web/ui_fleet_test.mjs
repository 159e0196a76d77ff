// Browser test of the fleet page on real processes: Mosquitto, two emulated robots (our
// firmware in simavr) each with its hub on the broker (`scaratwin hub --mqtt`, one with its own
// simulator), and the simulator that serves the page watching the broker (`scaratwin-sim
// --mqtt`), in Debian's chromium. The page must list both robots online; show the joints of the
// one jogged at its robot where the emulator's truth puts them (and the other's unmoved); show
// a command refused over MQTT in the robot's job; read "offline" for a hub that ends; and say so
// when the broker goes away.
//
// Usage: node ui_fleet_test.mjs --bin DIR --node-modules DIR --mosquitto EXE --mosquitto-pub EXE
//        [--chromium EXE]
// Prints one line per check and "N passed, N failed"; exits non-zero on any failure.
import { createRequire } from 'node:module';
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

import {
  Side, check, chromiumArgs, freePort, jointsOfSteps, parseArgs, results, sleep, start as startIn,
  stop, waitHttp, waitOutput,
} from './harness.mjs';

const args = parseArgs(process.argv.slice(2));
const { bin, mosquitto } = args;
const nodeModules = args['node-modules'];
const mosquittoPub = args['mosquitto-pub'];
const chromiumPath = args.chromium || '/usr/bin/chromium';
if (!bin || !nodeModules || !mosquitto || !mosquittoPub) {
  console.error('usage: ui_fleet_test.mjs --bin DIR --node-modules DIR --mosquitto EXE ' +
    '--mosquitto-pub EXE [--chromium EXE]');
  process.exit(2);
}
const require = createRequire(path.join(path.resolve(nodeModules), 'noop.js'));
const { chromium } = require('playwright-core');
const start = (exe, argv) => startIn(bin, exe, argv);

// the page's row of a robot: its cells' texts, or null while it has none
async function row(page, name) {
  const cells = page.locator(`tr[data-robot="${name}"] td`);
  if ((await cells.count()) === 0) return null;
  return cells.allTextContents();
}
async function waitRow(page, name, pred, timeoutMs) {
  const deadline = Date.now() + timeoutMs;
  let last = null;
  while (Date.now() < deadline) {
    last = await row(page, name);
    if (last && pred(last)) return { ok: true, cells: last };
    await sleep(100);
  }
  return { ok: false, cells: last };
}
const joints = (cells) => cells[3].split('·').map((v) => Number(v.trim()));

const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'scaratwin-fleet-'));
const procs = {};
let context = null;
let side = null;

try {
  const brokerPort = await freePort();
  const httpPort = await freePort();
  const conf = path.join(dir, 'mosquitto.conf');
  fs.writeFileSync(conf, `listener ${brokerPort} 127.0.0.1\nallow_anonymous true\n` +
    'persistence false\nset_tcp_nodelay true\n');
  const url = `mqtt://127.0.0.1:${brokerPort}`;
  procs.broker = start(mosquitto, ['-c', conf]);
  procs.simA = start('scaratwin-sim', ['--port', '0', '--http-port', String(httpPort), '--no-camera',
    '--mqtt', url]);
  procs.simB = start('scaratwin-sim', ['--port', '0', '--http-port', '0', '--no-camera']);
  procs.robotA = start('scaratwin-robot', ['--plant', 'ideal', '--pty-link', path.join(dir, 'a.pty')]);
  procs.robotB = start('scaratwin-robot', ['--plant', 'ideal', '--pty-link', path.join(dir, 'b.pty')]);
  const sideA = await waitOutput(procs.robotA, /side channel: 127\.0\.0\.1:(\d+)/, 30000);
  const robotB = await waitOutput(procs.robotB, /side channel: 127\.0\.0\.1:(\d+)/, 30000);
  const simA = await waitOutput(procs.simA, /listening on 127\.0\.0\.1:(\d+)/, 30000);
  const simB = await waitOutput(procs.simB, /listening on 127\.0\.0\.1:(\d+)/, 30000);
  const fleetLine = await waitOutput(procs.simA, /fleet page on (http\S+)/, 30000);
  const up = sideA && robotB && simA && simB && fleetLine && await waitHttp(httpPort, 30000);
  check('broker, robots, simulators and the fleet page are up', up,
    Object.values(procs).map((p) => p.output).join(' | '));
  if (!up) throw new Error('not up');
  side = new Side(Number(sideA[1]));
  await side.connect();
  await side.command('rate 0');
  const hubArgs = (name, pty, simPort) => ['hub', '--mqtt', url, '--name', name, '--state-hz', '20',
    '--serial', path.join(dir, pty), '--sim', `127.0.0.1:${simPort}`, '--no-db'];
  procs.hubA = start('scaratwin', hubArgs('cell-a', 'a.pty', simA[1]));
  procs.hubB = start('scaratwin', hubArgs('cell-b', 'b.pty', simB[1]));

  context = await chromium.launchPersistentContext(path.join(dir, 'chromium'), {
    executablePath: chromiumPath, headless: true, args: chromiumArgs,
  });
  const page = context.pages()[0] || await context.newPage();
  await page.goto(fleetLine[1]);
  const online = (cells) => cells[1] === 'online' && cells[2] !== '—';
  const a = await waitRow(page, 'cell-a', online, 30000);
  const b = await waitRow(page, 'cell-b', online, 30000);
  check('the page lists both robots online, with their state', a.ok && b.ok,
    `cell-a ${JSON.stringify(a.cells)}, cell-b ${JSON.stringify(b.cells)} | ${procs.hubA.output} | ${procs.hubB.output}`);
  check('the page says the broker is connected',
    (await page.locator('#conn b').textContent()) === 'broker connected');

  // jog robot A's J2 at the robot; its row must follow the physical robot, B's must not move
  const t0 = await side.truth();
  check('J2+ pressed at robot A', (await side.command('press j2+ 700')) === 'OK press j2+ 700');
  await sleep(1500);
  const t1 = await side.truth();
  const want = jointsOfSteps(t1.z - t0.z, t1.j2 - t0.j2, t1.j3 - t0.j3);
  const close = (cells) => {
    const j = joints(cells);
    return Math.abs(j[0] - want[0]) <= 0.06 && Math.abs(j[1] - want[1]) <= 0.06 &&
      Math.abs(j[2] - want[2]) <= 0.06;
  };
  const moved = await waitRow(page, 'cell-a', close, 5000);
  check('robot A moved', Math.abs(want[1]) > 10, JSON.stringify(want));
  check('cell-a\'s joints on the page are where the physical robot is', moved.ok,
    `page ${moved.cells && moved.cells[3]}, truth ${want.map((v) => v.toFixed(2)).join(' ')}`);
  const still = await row(page, 'cell-b');
  check('cell-b\'s joints have not moved', still && joints(still).every((v) => v === 0),
    still && still[3]);

  // a command refused over MQTT reaches the robot's job
  execFileSync(mosquittoPub, ['-p', String(brokerPort), '-t', 'scaratwin/v1/cell-a/command',
    '-q', '1', '-m', '{"id": "t1", "statement": "move 0.5 0 0.05"}']);
  const job = await waitRow(page, 'cell-a', (c) => c[9].includes('move 0.5 0 0.05') &&
    c[9].includes('0 ok, 1 failed'), 5000);
  check('a refused command shows in cell-a\'s job', job.ok, job.cells && job.cells[9]);

  // a hub that ends says offline (retained); the page shows it
  await stop(procs.hubB);
  const off = await waitRow(page, 'cell-b', (c) => c[1] === 'offline', 5000);
  check('cell-b reads offline once its hub ends', off.ok, off.cells && off.cells[1]);

  // the broker goes away: the page says so, and keeps the robots it knew
  await stop(procs.broker);
  let unreachable = false;
  for (let i = 0; i < 50 && !unreachable; ++i) {
    unreachable = (await page.locator('#conn b').textContent()) === 'broker unreachable';
    if (!unreachable) await sleep(100);
  }
  check('the page says the broker is unreachable', unreachable,
    await page.locator('#conn b').textContent());
  check('the page keeps the robots it knew', (await row(page, 'cell-a')) !== null);
  await page.screenshot({ path: path.join(args.artifacts || dir, 'fleet.png') }).catch(() => {});
  // the virtual robot's page links to the fleet page when its simulator watches a broker (the
  // link shows with the page's first scene message: on a machine busy with builds, the page and
  // its feed may take well over 5 s to come up, so the wait is for the event, not a deadline)
  await page.goto(`http://127.0.0.1:${httpPort}/`);
  const link = await page.locator('#fleet-link').isVisible().catch(() => false) ||
    await page.waitForSelector('#fleet-link', { state: 'visible', timeout: 30000 }).then(() => true, () => false);
  check('the robot\'s page links to the fleet page', link);
} catch (e) {
  check('test ran to the end', false, e.stack || String(e));
} finally {
  if (side) side.close();
  if (context) await context.close().catch(() => {});
  for (const name of ['hubA', 'hubB', 'simA', 'simB', 'robotA', 'robotB', 'broker']) {
    await stop(procs[name]);
  }
  fs.rmSync(dir, { recursive: true, force: true });
}
console.log(`${results.passed} passed, ${results.failed} failed`);
process.exit(results.failed === 0 ? 0 : 1);
