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
import { mkdtempSync, mkdirSync, rmSync, existsSync, readFileSync, writeFileSync } from 'node:fs';
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
// A full-page screenshot from the top (the header is sticky: taken scrolled, it would be drawn
// in the middle of the page).
async function fullShot(name) {
  await page.evaluate(() => window.scrollTo(0, 0));
  await page.screenshot({ path: join(shots, name), fullPage: true });
}
const text = (id) => page.$eval(`[data-testid="${id}"]`, (e) => e.textContent);
const events = () => page.$$eval('#events li', (l) => l.map((e) => e.textContent));

before(async () => {
  const port = await freeUdpPort();
  const robotAddr = `127.0.0.1:${port}`;
  start(['robot', '--sim', '--robot', 'sphere-omni', '--listen', robotAddr, '--watchdog', String(WATCHDOG_S),
    '--max-time', '600'], 'robot');
  const con = start(['console', '--connect', robotAddr, '--listen', '127.0.0.1:0', '--for', '300',
    '--record-dir', tmp, '--map', join(root, 'examples/maps/hall.toml')], 'console');
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
  // The console's --map (examples/maps/hall.toml) reached the page, which draws it.
  const map = await until('the map', async () => page.evaluate(() => typeof map === 'object' && map
    && { out: map.keep_out.length, keepIn: map.keep_in && map.keep_in.length }));
  assert.deepEqual(map, { out: 4, keepIn: 4 });
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
  // The mode first, then the pose: a pose read before the mode could be an update older than
  // the one that said idle (the robot still braking), and the check below would see it move.
  const stopped = await until('mode idle after release', async () => {
    if ((await text('mode')) !== 'idle') return null;
    return pose();
  }, 5000, 20);
  await page.keyboard.up('ArrowUp');
  const dt = stopped.t - before.t;
  assert.ok(dt <= WATCHDOG_S + 0.1, `stopped ${dt.toFixed(3)} s (robot time) after release, watchdog ${WATCHDOG_S} s`);
  await new Promise((r) => setTimeout(r, 600));
  const later = await pose();
  assert.ok(Math.hypot(later.x - stopped.x, later.y - stopped.y) < 0.002, `still moving: ${stopped.text} → ${later.text}`);
  assert.ok(later.x > p0.x + 0.05, 'moved forward (+x, robot frame = world frame at heading 0)');
  await fullShot('console-teleop.png');
});

test('e-stop button and Space key: the robot reports the e-stop', async () => {
  await page.click('[data-testid="estop"]');
  await until('mode estop', async () => (await text('mode')) === 'estop');
  // Latched: a full-width banner says so.
  const banner = await page.$eval('[data-testid="estop-banner"]', (e) => ({
    hidden: e.hidden, w: e.getBoundingClientRect().width, page: document.documentElement.clientWidth,
  }));
  assert.ok(!banner.hidden && banner.w >= banner.page - 1, `banner while latched: ${JSON.stringify(banner)}`);
  await until('the confirmation event', async () => (await events()).some((e) => e.includes('e-stop confirmed by the robot')));
  await fullShot('console-estop.png');
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
  assert.ok(await page.$eval('[data-testid="estop-banner"]', (e) => e.hidden), 'no banner after Clear');
});

// E-STOP on screen, inside the viewport, at every size and wherever the page is scrolled; no
// sideways scrolling; at 1280x800 the wheel plot starts on the first screen.
const SIZES = [[390, 844, 'phone'], [800, 600, 'laptop'], [1280, 800, 'desktop']];
test('E-STOP stays on screen at phone, laptop and desktop sizes', async () => {
  for (const [w, h, name] of SIZES) {
    await page.setViewportSize({ width: w, height: h });
    for (const at of ['top', 'bottom']) {
      await page.evaluate((y) => window.scrollTo(0, y), at === 'top' ? 0 : 1e6);
      await new Promise((r) => setTimeout(r, 100));
      const box = await page.$eval('[data-testid="estop"]', (e) => {
        const r = e.getBoundingClientRect();
        const hit = document.elementFromPoint(r.left + r.width / 2, r.top + r.height / 2);
        return { l: r.left, r: r.right, t: r.top, b: r.bottom, onTop: hit === e };
      });
      assert.ok(box.l >= 0 && box.r <= w && box.t >= 0 && box.b <= h && box.onTop,
        `${name} ${w}x${h}, scrolled to the ${at}: E-STOP at ${JSON.stringify(box)}`);
      if (at === 'top') await page.screenshot({ path: join(shots, `console-${name}.png`) });
    }
    const sideways = await page.evaluate(() => document.documentElement.scrollWidth - window.innerWidth);
    assert.ok(sideways <= 0, `${name}: the page is ${sideways} px wider than the screen`);
    const touch = await page.$eval('[data-testid="touch-pad"]', (e) => e.getBoundingClientRect().width > 0);
    assert.equal(touch, w <= 700, `${name}: touch pad shown ${touch}`);
  }
  await page.evaluate(() => window.scrollTo(0, 0));
  const plotTop = await page.$eval('#wheels', (e) => e.getBoundingClientRect().top);
  assert.ok(plotTop < 800 - 60, `desktop: the wheel plot starts at ${plotTop} px, below the first screen`);
});

test('touch teleop on a phone: holding the pad drives, lifting stops', async () => {
  await page.setViewportSize({ width: 390, height: 844 });
  await page.$eval('[data-testid="touch-pad"]', (e) => e.scrollIntoView({ block: 'center' }));
  const r = await page.$eval('[data-testid="touch-pad"]', (e) => { const b = e.getBoundingClientRect(); return { x: b.left, y: b.top, w: b.width, h: b.height }; });
  const p0 = await pose();
  // A finger in the pad's upper half: forward (robot +x; heading 0 here).
  await page.mouse.move(r.x + r.w / 2, r.y + r.h / 2);
  await page.mouse.down();
  await page.mouse.move(r.x + r.w / 2, r.y + r.h * 0.1, { steps: 4 });
  await until('the robot to move forward', async () => (await pose()).x > p0.x + 0.03, 10000);
  await until('mode velocity', async () => (await text('mode')) === 'velocity', 3000, 20);
  const before = await pose();
  await page.mouse.up();
  const stopped = await until('mode idle after lifting', async () => { const p = await pose(); return (await text('mode')) === 'idle' && p; }, 5000, 20);
  assert.ok(stopped.t - before.t <= WATCHDOG_S + 0.1, `stopped ${(stopped.t - before.t).toFixed(3)} s after lifting`);
  await page.screenshot({ path: join(shots, 'console-phone-teleop.png') });
  await page.setViewportSize({ width: 1280, height: 900 });
  await page.evaluate(() => window.scrollTo(0, 0));
});

test('one page holds the controls; another sees who, can only e-stop, and can take them', async () => {
  await until('this page holds the controls', async () => (await text('controls')) === 'you');
  const other = await context.newPage();
  other.on('pageerror', (e) => { console.error('page error (second page):', e); });
  try {
    await other.goto(url);
    const t2 = (id) => other.$eval(`[data-testid="${id}"]`, (e) => e.textContent);
    await until('the second page sees the holder', async () => /^page \d+ \(127\.0\.0\.1:\d+\)$/.test(await t2('controls')));
    assert.equal(await other.$eval('[data-testid="take-control"]', (e) => e.hidden), false);
    // Its dead-man teleop drives nothing.
    const p0 = await pose();
    await other.keyboard.down('Shift');
    await other.keyboard.down('ArrowUp');
    await new Promise((r) => setTimeout(r, 1000));
    assert.match(await other.textContent('#deadman'), /^view only: page \d+ .* holds the controls$/);
    await other.keyboard.up('ArrowUp');
    await other.keyboard.up('Shift');
    const p1 = await pose();
    assert.ok(Math.hypot(p1.x - p0.x, p1.y - p0.y) < 0.002, `a viewing page moved the robot: ${p0.text} → ${p1.text}`);
    // Its e-stop always works; the holder clears it.
    await other.click('[data-testid="estop"]');
    await until('mode estop from the second page', async () => (await text('mode')) === 'estop');
    await page.click('#clear');
    await until('cleared by the holder', async () => (await text('mode')) === 'idle' && (await text('faults')) === 'none');
    // An explicit take-over, told to the first page.
    await other.click('[data-testid="take-control"]');
    await until('the second page holds the controls', async () => (await t2('controls')) === 'you');
    await until('the first page is told', async () => /^page \d+ /.test(await text('controls')));
    assert.ok((await events()).some((e) => /took the controls from page/.test(e)));
    await page.screenshot({ path: join(shots, 'console-view-only.png') });
  } finally {
    await other.close();
  }
  await until('the controls free once the holder closed', async () => (await text('controls')) === 'free');
});

test('a square plan is uploaded, previewed and driven', async () => {
  const plan = join(tmp, 'square.csv');
  execFileSync(BIN, ['plan', 'square', '--robot', 'sphere-omni', '--speed', '0.2', '--out', plan], { stdio: 'ignore' });
  await page.setInputFiles('[data-testid="plan-upload"]', plan);
  await until('the preview', async () => (await page.textContent('#plan-info')).includes('841 samples'));
  await fullShot('console-preview.png');
  await page.check('#set-pose');
  await page.click('[data-testid="record"]');
  await until('recording', async () => (await page.textContent('#record-note')).startsWith('recording to'));
  await page.click('#plan-run');
  await until('plan running', async () => (await text('plan-state')).startsWith('running'), 15000);
  // Progress along the plan in plan time and percent (841 samples at 100 Hz: 8.4 s).
  await until('progress', async () => /^running \d+\.\d \/ 8\.4 s \(\d+ %\)$/.test(await text('plan-state')), 5000, 20);
  let maxX = -Infinity, maxY = -Infinity;
  let shot = false;
  await until('plan done', async () => {
    const p = await pose();
    maxX = Math.max(maxX, p.x); maxY = Math.max(maxY, p.y);
    if (!shot && maxX > 0.3 && p.y < 0.2) { shot = true; await fullShot('console.png'); }
    return (await text('plan-state')).startsWith('done');
  }, 60000, 100);
  const end = await pose();
  // The set-pose broke the trail (no line drawn across the jump).
  assert.ok(+(await page.$eval('#map', (e) => e.dataset.trailBreaks)) >= 1, 'the trail was not broken at the set-pose');
  await page.click('[data-testid="record"]');
  const rec = await until('the recording closed', async () => (await events()).find((e) => /recorded \d+ telemetry frames to .*\.mcap/.test(e)));
  assert.ok(existsSync(rec.match(/to (\S+\.mcap)/)[1]), rec);
  // Paper 000's square: legs +y, +x, -y, -x of 0.4 m from the plan's start (set as the pose).
  assert.ok(Math.abs(maxY - 0.4) < 0.05 && Math.abs(maxX - 0.4) < 0.05, `corners reached: max x ${maxX}, max y ${maxY}`);
  assert.ok(Math.hypot(end.x, end.y) < 0.05, `back at the start: ${end.text}`);
  await fullShot('console-done.png');
});

test('a plan far from the robot runs only after a second click', async () => {
  // The square shifted 0.5 m along x: its start is 0.5 m from the robot (back at the square's start).
  const src = join(tmp, 'square.csv'), far = join(tmp, 'far.csv');
  const lines = readFileSync(src, 'utf8').trim().split('\n');
  const ix = lines[0].split(',').indexOf('x');
  assert.ok(ix >= 0, lines[0]);
  writeFileSync(far, [lines[0], ...lines.slice(1).map((l) => { const c = l.split(','); c[ix] = String(+c[ix] + 0.5); return c.join(','); })].join('\n') + '\n');
  await page.setInputFiles('[data-testid="plan-upload"]', far);
  await until('the far preview', async () => (await page.textContent('#plan-info')).startsWith('far.csv'));
  await page.uncheck('#set-pose');
  await page.click('#plan-run');
  const warning = await until('the warning', async () => { const w = await page.$eval('[data-testid="plan-warning"]', (e) => !e.hidden && e.textContent); return w; });
  assert.match(warning, /is 0\.5\d m from the plan's start .* Click again/);
  await new Promise((r) => setTimeout(r, 500));
  assert.equal(await text('mode'), 'idle', 'the first click drove');
  assert.ok(!(await text('plan-state')).startsWith('uploading'));
  await page.click('#plan-run');
  await until('the plan runs after the second click', async () => (await text('plan-state')).startsWith('running'), 15000);
  await page.click('#stop');
  await until('stopped', async () => (await text('mode')) === 'idle', 10000);
});

// Last (it ends the robot): a robot that stops sending is shown as lost within two heartbeat
// periods (the console's default 20 Hz: 0.1 s) plus the page's 50 ms check; mode and faults
// become unknown instead of their last values.
test('a killed robot is shown as lost, mode and faults unknown', async () => {
  await until('link connected', async () => (await text('link-state')) === 'connected');
  const robot = children.find((c) => c.name === 'robot');
  const killed = Date.now();
  robot.kill('SIGKILL');
  await until('the lost banner', async () => !(await page.$eval('[data-testid="lost-banner"]', (e) => e.hidden)), 5000, 10);
  const after = Date.now() - killed;
  assert.ok(after < 2000, `shown ${after} ms after the kill`);
  assert.equal(await text('mode'), 'unknown');
  assert.equal(await text('faults'), 'unknown');
  assert.equal(await text('link-state'), 'robot lost');
  const age = await page.$eval('[data-testid="lost-banner"]', (e) => +e.dataset.ageS);
  assert.ok(age > 0.1, `lost only once the data is older than two heartbeat periods (age ${age} s)`);
  await page.screenshot({ path: join(shots, 'console-lost.png') });
});
