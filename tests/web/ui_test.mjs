// Browser test of the web UI: a real scaratwin-sim on free ports, Debian's chromium headless
// driven by playwright-core, and the hub's side of the virtual link played over TCP (JD packets).
//
// Usage: node ui_test.mjs --sim <scaratwin-sim> --node-modules <dir> --artifacts <dir>
// Prints one line per check and "N passed, N failed"; exits non-zero on any failure.
import { createRequire } from 'node:module';
import fs from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';

import { check, freePort, parseArgs, results, sleep, start, stop, waitHttp } from './harness.mjs';

const args = parseArgs(process.argv.slice(2));
const simExe = args.sim;
const nodeModules = args['node-modules'];
const artifacts = args.artifacts;
const chromiumPath = args.chromium || '/usr/bin/chromium';
if (!simExe || !nodeModules || !artifacts) {
  console.error('usage: ui_test.mjs --sim EXE --node-modules DIR --artifacts DIR [--chromium EXE]');
  process.exit(2);
}
const require = createRequire(path.join(path.resolve(nodeModules), 'noop.js'));
const { chromium } = require('playwright-core');

// --- the simulator -------------------------------------------------------------------------------
const startSim = (tcpPort, httpPort) =>
  start('', path.resolve(simExe), ['--port', String(tcpPort), '--http-port', String(httpPort)]);
const stopSim = (proc) => stop(proc);

// --- the hub's side of the virtual link ----------------------------------------------------------
class Hub {
  constructor(port) {
    this.port = port;
    this.seq = 0;
    this.rx = '';
  }
  connect() {
    return new Promise((resolve, reject) => {
      this.sock = net.connect(this.port, '127.0.0.1', resolve);
      this.sock.once('error', reject);
      this.sock.on('data', (d) => { this.rx += d.toString('latin1'); });
    });
  }
  send(line) { this.sock.write(`${line}\n`); }
  // joints in wire units: d1 mm, angles deg; t_us on this machine's monotonic clock
  joints(d1, q2, q3, q4) {
    const tUs = Number(process.hrtime.bigint() / 1000n % 4294967296n);
    this.send(`JD,${this.seq},${tUs},${d1},${q2},${q3},${q4},`);
    this.seq = (this.seq + 1) % 65536;
  }
  close() { if (this.sock) this.sock.destroy(); }
}

// --- the test ------------------------------------------------------------------------------------
const tcpPort = await freePort();
const httpPort = await freePort();
const url = `http://127.0.0.1:${httpPort}/`;
fs.mkdirSync(artifacts, { recursive: true });
const userDir = fs.mkdtempSync(path.join(os.tmpdir(), 'scaratwin-ui-'));
let sim = startSim(tcpPort, httpPort);
let context = null;
let hub = null;
let mover = null;

try {
  const up = await waitHttp(httpPort, 30000);
  check('simulator serves http', up, up ? url : sim.output);
  if (!up) throw new Error('simulator did not start');

  context = await chromium.launchPersistentContext(userDir, {
    executablePath: chromiumPath,
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
    viewport: { width: 1600, height: 960 },
  });
  const page = context.pages()[0] || await context.newPage();
  const consoleErrors = [];
  page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  page.on('pageerror', (e) => consoleErrors.push(`pageerror: ${e.message}`));
  // the page must not reach out to the internet
  const foreign = [];
  page.on('request', (r) => { if (!r.url().startsWith(`http://127.0.0.1:${httpPort}/`) && !r.url().startsWith('ws://127.0.0.1') && !r.url().startsWith('data:')) foreign.push(r.url()); });

  await page.goto(url);
  await page.waitForFunction(() => window.scaratwin && window.scaratwin.state !== null, null, { timeout: 20000 });
  check('page loads and receives the feed', true);
  const bodies = await page.evaluate(() => window.scaratwin.scene.bodies.length);
  check('scene geometry received', bodies > 5, `${bodies} bodies`);
  check('no cubes at start', await page.locator('#cube-list tr').count() === 0);
  check('one robot: no workcell table', await page.locator('#robots-card').isHidden());

  // clicking red makes a red cube appear in the scene and in the cube list
  await page.click('#spawn-red');
  await page.waitForSelector('#cube-list tr[data-color="red"]', { timeout: 5000 });
  const red = await page.evaluate(() => window.scaratwin.visibleCubes());
  check('red cube in data area 2', await page.locator('#cube-list tr[data-color="red"]').count() === 1);
  const rgb = red.length === 1 ? parseInt(red[0].rgb, 16) : 0;
  const [r8, g8, b8] = [(rgb >> 16) & 255, (rgb >> 8) & 255, rgb & 255];
  check('red cube drawn in the 3D scene', red.length === 1 && red[0].color === 'red' && r8 > 2 * g8 && r8 > 2 * b8,
    JSON.stringify(red));
  const restZ = await page.evaluate(() => window.scaratwin.scene.table_z + window.scaratwin.scene.cube_size / 2);
  const onTable = red.length === 1 && Math.abs(red[0].pos[2] - restZ) < 0.005;
  check('red cube rests on the table', onTable, red.length ? `z ${red[0].pos[2].toFixed(4)} m` : '');

  // typed coordinates
  // typed coordinates (a spot well away from the random red one)
  const spots = [[130, 90], [210, 70]];
  const redXY = red.length ? [red[0].pos[0] * 1e3, red[0].pos[1] * 1e3] : [0, 0];
  const [tx, ty] = spots.sort((a, b) => Math.hypot(b[0] - redXY[0], b[1] - redXY[1]) - Math.hypot(a[0] - redXY[0], a[1] - redXY[1]))[0];
  await page.fill('#spawn-x', String(tx));
  await page.fill('#spawn-y', String(ty));
  await page.click('#spawn-blue');
  await page.waitForSelector('#cube-list tr[data-color="blue"]', { timeout: 5000 }).catch(() => {});
  const blueRow = await page.locator('#cube-list tr[data-color="blue"] td').allTextContents();
  check('blue cube at the typed coordinates', Math.abs(Number(blueRow[2]) - tx) < 2 && Math.abs(Number(blueRow[3]) - ty) < 2,
    `${blueRow.join(' ')} ${await page.locator('#toast').textContent()}`);
  await page.fill('#spawn-x', '');
  await page.fill('#spawn-y', '');

  // reset removes them
  await page.click('#reset');
  await page.waitForFunction(() => document.querySelectorAll('#cube-list tr').length === 0, null, { timeout: 5000 });
  const left = await page.evaluate(() => window.scaratwin.visibleCubes().length);
  check('reset removes the cubes from the list and the scene', left === 0, `${left} left`);

  // joint values follow JD packets from the hub
  hub = new Hub(tcpPort);
  await hub.connect();
  hub.send('HI,1,');
  hub.send('MD,mirror,');
  const before = await page.locator('#joint-q2 .value').textContent();
  for (let i = 0; i < 10; i++) {
    hub.joints(80, 30, -45, 20);
    await sleep(20);
  }
  await page.waitForFunction(() => document.querySelector('#joint-q2 .value').textContent === '30.0', null, { timeout: 5000 })
    .catch(() => {});
  const q = await page.locator('.joint .value').allTextContents();
  check('joint values change when the robot moves', before !== q[1] && q[0] === '80.0' && q[1] === '30.0' && q[2] === '-45.0' && q[3] === '20.0',
    `before q2 ${before}, now ${q.join(' ')}`);
  const link = await page.evaluate(() => window.scaratwin.state.link);
  check('link status, frames and latency shown', link.connected && link.frames >= 10 && link.latency_ms !== undefined &&
    (await page.locator('#link-state').textContent()) === 'connected', JSON.stringify(link));
  check('mirror mode shown', (await page.locator('#mode .on').textContent()) === 'Mirror');
  // the hub says which of the twin's modes it runs (TW); none: derived again
  hub.send('TW,control,');
  await page.waitForFunction(() => document.querySelector('#mode .on')?.textContent === 'Control', null, { timeout: 5000 })
    .catch(() => {});
  check('the mode the hub announces is shown', (await page.locator('#mode .on').textContent()) === 'Control');
  hub.send('TW,none,');
  await page.waitForFunction(() => document.querySelector('#mode .on')?.textContent === 'Mirror', null, { timeout: 5000 })
    .catch(() => {});
  check('without an announced mode the simulator\'s is shown', (await page.locator('#mode .on').textContent()) === 'Mirror');

  // an out-of-limit joint is highlighted
  hub.joints(80, 130, -45, 20);
  await page.waitForSelector('#joint-q2.out', { timeout: 5000 }).catch(() => {});
  check('out-of-limit joint highlighted', await page.locator('#joint-q2.out').count() === 1 &&
    await page.locator('#joint-q3.out').count() === 0);
  // lost frames: skip 5 sequence numbers
  hub.seq = (hub.seq + 5) % 65536;
  hub.joints(80, 30, -45, 20);
  await page.waitForFunction(() => window.scaratwin.state.link.lost >= 5, null, { timeout: 5000 }).catch(() => {});
  check('lost frames counted', (await page.locator('#lost').textContent()) === '5');

  // camera picture
  await page.click('#shoot');
  await page.waitForSelector('#shot:not([hidden])', { timeout: 15000 }).catch(() => {});
  const shot = await page.evaluate(() => { const i = document.getElementById('shot-img'); return [i.naturalWidth, i.naturalHeight]; });
  check('camera picture shown', shot[0] === 640 && shot[1] === 480, `${shot[0]}x${shot[1]}`);

  // a second browser sees the same scene
  const page2 = await context.newPage();
  await page2.goto(url);
  await page2.waitForFunction(() => window.scaratwin && window.scaratwin.state !== null, null, { timeout: 20000 });
  await page.click('#spawn-green');
  await page2.waitForSelector('#cube-list tr[data-color="green"]', { timeout: 5000 }).catch(() => {});
  check('a second browser sees the cube spawned in the first', await page2.locator('#cube-list tr[data-color="green"]').count() === 1);
  const clients = await page.evaluate(() => window.scaratwin.state.clients);
  check('both browsers counted', clients === 2, `${clients}`);
  await page2.close();

  check('no console errors', consoleErrors.length === 0, consoleErrors.join(' | '));
  check('no request leaves the simulator', foreign.length === 0, foreign.join(' '));

  // a scene for the screenshot: cubes and a sweeping arm leaving a tool path
  await page.click('#spawn-red');
  await page.click('#spawn-blue');
  await page.click('#spawn-green');
  await page.click('#spawn-red');
  let k = 0;
  mover = setInterval(() => {
    const s = k++ / 100;
    hub.joints((70 + 30 * Math.sin(2 * s)).toFixed(2), (40 * Math.sin(s)).toFixed(2), (60 + 50 * Math.sin(1.7 * s)).toFixed(2), (90 + 60 * Math.sin(s)).toFixed(2));
  }, 10);
  await sleep(4000);
  await page.click('#shoot');
  await page.waitForTimeout(1500);
  const shotPath = path.join(artifacts, 'ui.png');
  await page.screenshot({ path: shotPath });
  check('screenshot saved', fs.existsSync(shotPath) && fs.statSync(shotPath).size > 10000, shotPath);
  clearInterval(mover);
  mover = null;

  // the page survives a simulator restart and reconnects by itself
  hub.close();
  hub = null;
  await stopSim(sim);
  await page.waitForSelector('#conn.down', { timeout: 5000 }).catch(() => {});
  check('page notices the simulator is gone', await page.locator('#conn.down').count() === 1);
  sim = startSim(tcpPort, httpPort);
  const again = await waitHttp(httpPort, 30000);
  await page.waitForSelector('#conn.live', { timeout: 15000 }).catch(() => {});
  const cubesAfter = await page.evaluate(() => window.scaratwin.state.cubes.length);
  check('page reconnects after a simulator restart', again && await page.locator('#conn.live').count() === 1 && cubesAfter === 0,
    `http ${again}, cubes ${cubesAfter}`);
} catch (e) {
  check('test ran to the end', false, e.stack || String(e));
} finally {
  if (mover) clearInterval(mover);
  if (hub) hub.close();
  if (context) await context.close().catch(() => {});
  await stopSim(sim);
  fs.rmSync(userDir, { recursive: true, force: true });
}
console.log(`${results.passed} passed, ${results.failed} failed`);
process.exit(results.failed === 0 ? 0 : 1);
