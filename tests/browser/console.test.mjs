// End-to-end test of `omnikin console` in a real browser: Debian's chromium driven by
// playwright-core (no browser download). Starts `omnikin robot --sim` and `omnikin console`,
// opens the printed URL and drives the robot from the page: dead-man teleop, release → stop
// within the watchdog time, e-stop (button and Space) confirmed by the robot, a square plan
// uploaded from a file and driven to the end while recorded to MCAP; a request without the token gets 403.
//
// Env: OMNIKIN_BIN (default target/debug/omnikin), CHROMIUM (default /usr/bin/chromium),
// SCREENSHOT_DIR (where console*.png go; default a temporary directory).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { spawn, execFileSync } from 'node:child_process';
import { mkdtempSync, mkdirSync, rmSync, existsSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import dgram from 'node:dgram';
import { chromium } from 'playwright-core';

const root = resolve(dirname(fileURLToPath(import.meta.url)), '../..');
const BIN = process.env.OMNIKIN_BIN || join(root, 'target/debug/omnikin');
const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
const tmp = mkdtempSync(join(tmpdir(), 'omnikin-console-e2e-'));
const shots = process.env.SCREENSHOT_DIR || join(tmp, 'shots');
mkdirSync(shots, { recursive: true });
const WATCHDOG_S = 0.5; // the robot's --watchdog (its default), robot time

const children = [];
let context, page, url, base;

function freeUdpPort() {
  return new Promise((res, rej) => {
    const s = dgram.createSocket('udp4');
    s.on('error', rej);
    s.bind(0, '127.0.0.1', () => { const p = s.address().port; s.close(() => res(p)); });
  });
}

function start(args, name) {
  const c = spawn(BIN, args, { stdio: ['ignore', 'pipe', 'pipe'] });
  c.out = ''; c.err = '';
  c.stdout.on('data', (d) => { c.out += d; });
  c.stderr.on('data', (d) => { c.err += d; });
  c.name = name;
  children.push(c);
  return c;
}

async function until(what, fn, ms = 10000, every = 50) {
  const end = Date.now() + ms;
  for (;;) {
    const v = await fn();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out after ${ms} ms waiting for ${what}`);
    await new Promise((r) => setTimeout(r, every));
  }
}

async function pose() {
  return page.$eval('[data-testid="pose"]', (e) => ({
    text: e.textContent, x: +e.dataset.x, y: +e.dataset.y, heading: +e.dataset.heading, t: +e.dataset.t,
  }));
}
const text = (id) => page.$eval(`[data-testid="${id}"]`, (e) => e.textContent);
const events = () => page.$$eval('#events li', (l) => l.map((e) => e.textContent));

before(async () => {
  const port = await freeUdpPort();
  const robotAddr = `127.0.0.1:${port}`;
  start(['robot', '--sim', '--robot', 'sphere-omni', '--listen', robotAddr, '--watchdog', String(WATCHDOG_S),
    '--max-time', '600'], 'robot');
  const con = start(['console', '--connect', robotAddr, '--listen', '127.0.0.1:0', '--for', '300',
    '--record-dir', tmp], 'console');
  const line = await until('the console URL', () => con.out.match(/http:\/\/127\.0\.0\.1:\d+\/\?token=[0-9a-f]{32}/), 15000);
  url = line[0];
  base = url.replace(/\/\?token=.*/, '');
  context = await chromium.launchPersistentContext(join(tmp, 'profile'), {
    executablePath: CHROMIUM,
    headless: true,
    viewport: { width: 1280, height: 900 },
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  page = context.pages()[0] || await context.newPage();
  page.on('pageerror', (e) => { console.error('page error:', e); });
});

after(async () => {
  if (context) await context.close().catch(() => {});
  for (const c of children) c.kill('SIGTERM');
  for (const c of children) if (c.exitCode == null) await new Promise((r) => { c.once('exit', r); setTimeout(r, 3000); });
  for (const c of children) if (c.exitCode == null) c.kill('SIGKILL');
  if (!process.env.SCREENSHOT_DIR) rmSync(tmp, { recursive: true, force: true });
  else rmSync(join(tmp, 'profile'), { recursive: true, force: true });
});

test('requests without the token are refused', async () => {
  for (const path of ['/', '/app.js', '/style.css', '/ws', '/?token=', '/?token=00000000000000000000000000000000']) {
    const r = await fetch(base + path);
    assert.equal(r.status, 403, path);
  }
  const ok = await fetch(url);
  assert.equal(ok.status, 200);
  assert.match(await ok.text(), /data-testid="estop"/);
});

test('the page connects and shows the pose', async () => {
  await page.goto(url);
  await until('link connected', async () => (await text('link-state')) === 'connected');
  const p = await until('telemetry', async () => { const p = await pose(); return Number.isFinite(p.t) && p; });
  assert.match(p.text, /x -?\d+\.\d+ m, y -?\d+\.\d+ m, heading -?\d+\.\d+ rad/);
  // A simulated robot sends its plant's truth: shown beside the estimate (ideal plant: equal).
  const truth = await until('the truth readout', async () => {
    const t = await page.$eval('[data-testid="truth"]', (e) => ({
      hidden: e.hidden, text: e.textContent, x: +e.dataset.x, y: +e.dataset.y,
    }));
    return !t.hidden && Number.isFinite(t.x) && t;
  });
  assert.match(truth.text, /truth x -?\d+\.\d+ m, y -?\d+\.\d+ m, heading -?\d+\.\d+ rad/);
  const q = await pose();
  assert.ok(Math.hypot(truth.x - q.x, truth.y - q.y) < 0.05, `truth ${truth.text} vs estimate ${q.text}`);
});

test('dead-man teleop moves the robot; release stops it within the watchdog time', async () => {
  const p0 = await pose();
  await page.keyboard.down('Shift');
  await page.keyboard.down('ArrowUp');
  await until('the robot to move forward', async () => (await pose()).x > p0.x + 0.05, 10000);
  // Without the dead-man the arrow does nothing: the robot must stop while the arrow stays down.
  const before = await pose();
  await page.keyboard.up('Shift');
  const stopped = await until('mode idle after release', async () => {
    const p = await pose();
    return (await text('mode')) === 'idle' && p;
  }, 5000, 20);
  await page.keyboard.up('ArrowUp');
  const dt = stopped.t - before.t;
  assert.ok(dt <= WATCHDOG_S + 0.1, `stopped ${dt.toFixed(3)} s (robot time) after release, watchdog ${WATCHDOG_S} s`);
  await new Promise((r) => setTimeout(r, 600));
  const later = await pose();
  assert.ok(Math.hypot(later.x - stopped.x, later.y - stopped.y) < 0.002, `still moving: ${stopped.text} → ${later.text}`);
  assert.ok(later.x > p0.x + 0.05, 'moved forward (+x, robot frame = world frame at heading 0)');
  await page.screenshot({ path: join(shots, 'console-teleop.png'), fullPage: true });
});

test('e-stop button and Space key: the robot reports the e-stop', async () => {
  await page.click('[data-testid="estop"]');
  await until('mode estop', async () => (await text('mode')) === 'estop');
  await until('the confirmation event', async () => (await events()).some((e) => e.includes('e-stop confirmed by the robot')));
  await page.screenshot({ path: join(shots, 'console-estop.png'), fullPage: true });
  await page.click('#clear');
  await until('mode idle after clear', async () => (await text('mode')) === 'idle' && (await text('faults')) === 'none');
  // Space while the dead-man and an arrow are held (other controls busy).
  await page.keyboard.down('Shift');
  await page.keyboard.down('KeyW');
  await until('moving again', async () => (await text('mode')) === 'velocity');
  await page.keyboard.press('Space');
  await until('mode estop by Space', async () => (await text('mode')) === 'estop', 3000);
  await page.keyboard.up('KeyW');
  await page.keyboard.up('Shift');
  await page.click('#clear');
  await until('cleared', async () => (await text('mode')) === 'idle' && (await text('faults')) === 'none');
});

test('a square plan is uploaded, previewed and driven', async () => {
  const plan = join(tmp, 'square.csv');
  execFileSync(BIN, ['plan', 'square', '--robot', 'sphere-omni', '--speed', '0.2', '--out', plan], { stdio: 'ignore' });
  await page.setInputFiles('[data-testid="plan-upload"]', plan);
  await until('the preview', async () => (await page.textContent('#plan-info')).includes('841 samples'));
  await page.screenshot({ path: join(shots, 'console-preview.png'), fullPage: true });
  await page.check('#set-pose');
  await page.click('[data-testid="record"]');
  await until('recording', async () => (await page.textContent('#record-note')).startsWith('recording to'));
  await page.click('#plan-run');
  await until('plan running', async () => (await text('plan-state')).startsWith('running'), 15000);
  let maxX = -Infinity, maxY = -Infinity;
  let shot = false;
  await until('plan done', async () => {
    const p = await pose();
    maxX = Math.max(maxX, p.x); maxY = Math.max(maxY, p.y);
    if (!shot && maxX > 0.3 && p.y < 0.2) { shot = true; await page.screenshot({ path: join(shots, 'console.png'), fullPage: true }); }
    return (await text('plan-state')).startsWith('done');
  }, 60000, 100);
  const end = await pose();
  await page.click('[data-testid="record"]');
  const rec = await until('the recording closed', async () => (await events()).find((e) => /recorded \d+ telemetry frames to .*\.mcap/.test(e)));
  assert.ok(existsSync(rec.match(/to (\S+\.mcap)/)[1]), rec);
  // Paper 000's square: legs +y, +x, -y, -x of 0.4 m from the plan's start (set as the pose).
  assert.ok(Math.abs(maxY - 0.4) < 0.05 && Math.abs(maxX - 0.4) < 0.05, `corners reached: max x ${maxX}, max y ${maxY}`);
  assert.ok(Math.hypot(end.x, end.y) < 0.05, `back at the start: ${end.text}`);
  await page.screenshot({ path: join(shots, 'console-done.png'), fullPage: true });
});
