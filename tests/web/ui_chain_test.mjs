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
import path from 'node:path';

import {
  check, chromiumArgs, jointsOfSteps, parseArgs, results, sleep, start as startIn, startChain,
  stopChain,
} from './harness.mjs';

const args = parseArgs(process.argv.slice(2));
const bin = args.bin;
const nodeModules = args['node-modules'];
const chromiumPath = args.chromium || '/usr/bin/chromium';
if (!bin || !nodeModules) {
  console.error('usage: ui_chain_test.mjs --bin DIR --node-modules DIR [--chromium EXE]');
  process.exit(2);
}
const require = createRequire(path.join(path.resolve(nodeModules), 'noop.js'));
const { chromium } = require('playwright-core');
const start = (exe, argv) => startIn(bin, exe, argv);

let chain = null;
let mirror = null;
let context = null;

try {
  // `scaratwin home`, then `scaratwin mirror`: two processes, each opening the port, on one
  // homed robot: the board with its auto-reset cut (a Uno would come back un-homed)
  chain = await startChain(bin, { robotArgs: ['--plant', 'ideal', '--no-auto-reset'] });
  const { links, side, httpPort, dir } = chain;

  // the counts are the joints' only once homed
  const home = start('scaratwin', ['home', ...links]);
  const homeStatus = await home.exited;
  check('scaratwin home', homeStatus === 0, home.output);

  context = await chromium.launchPersistentContext(path.join(dir, 'chromium'), {
    executablePath: chromiumPath,
    headless: true,
    args: chromiumArgs,
  });
  const page = context.pages()[0] || await context.newPage();
  await page.goto(`http://127.0.0.1:${httpPort}/`);
  await page.waitForFunction(() => window.scaratwin && window.scaratwin.state !== null, null, { timeout: 20000 });
  // homing passed the soft limits on its way to the switches; the hub said it was homing, so
  // the simulator took none of it for a limit warning
  check('no limit warning from homing', (await page.locator('#warn-count').textContent()) === 'within limits',
    `${await page.locator('#warn-count').textContent()}: ${JSON.stringify(await page.evaluate(() => window.scaratwin.state.warnings))}`);
  const framesBefore = await page.evaluate(() => window.scaratwin.state.link.frames);
  const lostBefore = await page.evaluate(() => window.scaratwin.state.link.lost);

  // mirror while the operator presses J2+ and then Z- at the robot
  mirror = start('scaratwin', ['mirror', '--seconds', '8', ...links]);
  await sleep(1500);
  check('J2+ pressed', (await side.command('press j2+ 700')) === 'OK press j2+ 700');
  await sleep(1500);
  check('Z- pressed', (await side.command('press z- 500')) === 'OK press z- 500');
  // the page's latency starts where the report's does, at the robot's sample: the hub aligns
  // the robot's clock to its own, so no frame can show less than the wire time of one state
  // report (55 bytes at 115200 baud, 4.774 ms) that the report's alignment takes off too
  // (before: the hub's receive time, 0.1-2 ms)
  await sleep(1000);
  const live = await page.evaluate(() => window.scaratwin.state.link);
  check('the page\'s latency runs from the robot\'s sample',
    live.latency_ms >= 4.77 && live.latency_mean_ms >= 4.77 && live.latency_mean_ms < 100,
    `last ${live.latency_ms} ms, mean ${live.latency_mean_ms} ms`);
  const mirrorStatus = await mirror.exited;
  const report = mirror.output.match(/(\d+) frames mirrored, (\d+) lost/);
  check('scaratwin mirror', mirrorStatus === 0 && report !== null, mirror.output);

  // where the physical robot is, converted from its true motor steps
  const t = await side.truth();
  const z = Number(t.z), j2 = Number(t.j2), j3 = Number(t.j3);
  const want = jointsOfSteps(z, j2, j3);
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
  await stopChain(chain, context, mirror);
}
console.log(`${results.passed} passed, ${results.failed} failed`);
process.exit(results.failed === 0 ? 0 : 1);
