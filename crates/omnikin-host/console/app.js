// omnikin console: plain JS + canvas, no framework. Talks to the console server over one
// websocket (same origin, ?token= of the page). The e-stop is handled first on every path:
// pointerdown on the button, Space on window (capture phase), gamepad button B.
'use strict';

const token = new URLSearchParams(location.search).get('token') || '';
const $ = (id) => document.getElementById(id);

// ---- state ----
let ws = null;
let config = { speed: 0.2, turn: 1.0 };
let robot = null;          // link info (RobotInfo)
let last = null;           // newest telemetry
let map = null;            // the console's --map: { keep_out: [{circle}|{polygon}], keep_in }
let plan = null;           // plan being run / loaded: { name, points: [[x,y,h],...] }
let planState = '';
const TRAIL_MAX = 4000;    // trail points kept
const trail = [];          // [x, y], or null where the estimate was set (no line across)
let trailBreaks = 0;
const truthTrail = [];
const HISTORY_S = 20;      // plot window, s (robot time)
const hist = [];           // { t, cmd[], meas[], err, twistErr }
const HIST_MAX = 2000;
const EVENTS_MAX = 200;
// Liveness: the robot is shown as lost when no telemetry has arrived for this many heartbeat
// periods of the console (--heartbeat, 20 Hz by default: 0.1 s).
const LOST_PERIODS = 2;
let lastDataAt = null;     // performance.now() of the newest telemetry
let lost = false;
// Control ownership: one page holds the controls (the hub decides); the others view and e-stop.
let me = null, holder = null, holderName = null;
const viewOnly = () => holder != null && holder !== me;
function showControls() {
  const el = $('controls');
  el.textContent = holder == null ? 'free' : holder === me ? 'you' : holderName;
  $('controls-pill').className = 'pill ' + (holder === me ? 'ok' : holder == null ? '' : 'warn');
  $('take-control').hidden = !viewOnly();
  for (const id of ['clear', 'stop', 'plan-upload']) $(id).disabled = viewOnly();
  $('plan-run').disabled = viewOnly() || !plan || planState === 'uploading' || planState === 'running';
  if (viewOnly()) releaseAll();
}

// ---- websocket ----
function send(obj) {
  if (ws && ws.readyState === WebSocket.OPEN) { ws.send(JSON.stringify(obj)); return true; }
  return false;
}

function connect() {
  setLink('connecting', 'opening the page socket');
  ws = new WebSocket(`ws://${location.host}/ws?token=${encodeURIComponent(token)}`);
  ws.onmessage = (e) => {
    let m;
    try { m = JSON.parse(e.data); } catch (_) { return; }
    handle(m);
  };
  ws.onclose = () => { setLink('offline', 'page socket closed: reconnecting'); setTimeout(connect, 1000); };
  ws.onerror = () => {};
}

function handle(m) {
  switch (m.type) {
    case 'page': me = m.id; showControls(); break;
    case 'control': holder = m.holder; holderName = m.name; showControls(); break;
    case 'config': config = m; $('record').disabled = !m.mcap; break;
    case 'record': recordState(m); break;
    case 'link': robot = m.robot || robot; setLink(m.state, m.detail, m); break;
    case 'telemetry': telemetry(m); break;
    case 'plan': plan = m; disarm(); planInfo(); break;
    case 'map': map = m; break;
    case 'pose_set': trail.push(null); trailBreaks++; $('map').dataset.trailBreaks = trailBreaks; break;
    case 'plan_status': planStatus(m); break;
    case 'event': addEvent(m.level, m.text, m.robot_t); break;
    case 'error': addEvent('error', m.text, null); break;
  }
}

// Three decimals, without a "-0.000".
function fix3(v) { const s = v.toFixed(3); return s === '-0.000' ? '0.000' : s; }

// ---- link / status ----
let linkMsg = null;
let linkState = 'connecting';
// The link pill: the relay's state, unless the page has had no telemetry for too long.
function showLink() {
  const el = $('link-state');
  const state = lost && linkState === 'connected' ? 'robot lost' : linkState;
  el.textContent = state === 'held' ? 'held by another operator' : state;
  $('link-pill').className = 'pill ' + (state === 'connected' ? 'ok' : (state === 'connecting' || state === 'held') ? 'warn' : 'bad');
}

// Called every 50 ms: the robot is lost when its newest data is older than LOST_PERIODS
// heartbeat periods. Mode and faults are then unknown, not their last values.
function liveness() {
  if (lastDataAt == null) return;
  const age = (performance.now() - lastDataAt) / 1000;
  const limit = LOST_PERIODS / (config.heartbeat_hz || 20);
  const nowLost = age > limit;
  if (nowLost) {
    $('lost-age').textContent = `${age.toFixed(1)} s`;
    $('lost-banner').dataset.ageS = age.toFixed(3);
  }
  if (nowLost === lost) return;
  lost = nowLost;
  document.body.classList.toggle('lost', lost);
  $('lost-banner').hidden = !lost;
  if (lost) {
    $('mode').textContent = 'unknown';
    $('faults').textContent = 'unknown';
    $('mode-pill').className = 'pill'; $('faults-pill').className = 'pill';
    $('estop-banner').hidden = true;
    addEvent('error', `robot lost: no telemetry for more than ${limit.toFixed(2)} s`, null);
  } else {
    addEvent('info', 'telemetry again', last ? last.t : null);
  }
  showLink();
}
setInterval(liveness, 50);
function setLink(state, detail, m) {
  const el = $('link-state');
  el.title = detail || '';
  // 'held': another operator's session is live; a control (or E-STOP) here takes it over.
  linkState = state;
  if (m) linkMsg = m;
  showLink();
  linkTable();
}

function linkTable() {
  const rows = [];
  const m = linkMsg;
  if (m) {
    rows.push(['robot', m.addr]);
    rows.push(['state', `${m.state}: ${m.detail}`]);
    if (m.session) rows.push(['session', m.session]);
  }
  if (robot) {
    rows.push(['model', `${robot.kind}, ${robot.rate_hz} Hz, watchdog ${robot.watchdog_s} s`]);
    rows.push(['auth', robot.authenticated ? 'key (HMAC tags)' : 'no key']);
  }
  if (last) {
    const r = last.robot_link, c = last.console_link;
    rows.push(['telemetry', `${last.frames} frames, t ${last.t.toFixed(2)} s`]);
    rows.push(['robot rx', `ok ${r.ok}, dropped ${r.dropped} (crc ${r.crc}, auth ${r.auth}, replay ${r.replay}, session ${r.session})`]);
    rows.push(['console rx', `ok ${c.ok}, dropped ${c.dropped} (crc ${c.crc}, auth ${c.auth}, replay ${c.replay}, session ${c.session})`]);
    rows.push(['commands', `acked seq ${last.ack_seq}, rejected ${last.rejected}`]);
  }
  const t = $('link-table');
  t.replaceChildren(...rows.map(([k, v]) => {
    const tr = document.createElement('tr');
    const a = document.createElement('td'); a.textContent = k;
    const b = document.createElement('td'); b.textContent = v;
    tr.append(a, b);
    return tr;
  }));
}

function telemetry(m) {
  last = m;
  lastDataAt = performance.now();
  if (lost) liveness();
  const [x, y, h] = m.pose;
  $('pose').textContent = `x ${fix3(x)} m, y ${fix3(y)} m, heading ${fix3(h)} rad`;
  $('pose').dataset.x = x; $('pose').dataset.y = y; $('pose').dataset.heading = h; $('pose').dataset.t = m.t;
  $('mode').textContent = m.mode;
  $('mode-pill').className = 'pill ' + (m.mode === 'estop' ? 'bad' : m.mode === 'idle' ? '' : 'ok');
  $('faults').textContent = m.fault_history;
  $('faults-pill').className = 'pill ' + (m.fault_history === 'none' ? '' : 'warn');
  $('estop').classList.toggle('latched', m.mode === 'estop');
  $('estop-banner').hidden = m.mode !== 'estop';
  if (m.truth) {
    const [tx, ty, th] = m.truth;
    $('truth').hidden = false;
    $('truth').textContent = `truth x ${fix3(tx)} m, y ${fix3(ty)} m, heading ${fix3(th)} rad (|estimate − truth| ${fix3(Math.hypot(x - tx, y - ty))} m)`;
    $('truth').dataset.x = tx; $('truth').dataset.y = ty; $('truth').dataset.heading = th;
    $('truth-note').textContent = 'truth (simulation)';
    const tt = truthTrail.length ? truthTrail[truthTrail.length - 1] : null;
    if (!tt || Math.hypot(tt[0] - tx, tt[1] - ty) > 0.002) {
      truthTrail.push([tx, ty]);
      if (truthTrail.length > TRAIL_MAX) truthTrail.shift();
    }
  }
  const tl = trail.length ? trail[trail.length - 1] : null;
  if (!tl || Math.hypot(tl[0] - x, tl[1] - y) > 0.002) {
    while (trail.length && trail[0] === null) trail.shift();
    trail.push([x, y]);
    if (trail.length > TRAIL_MAX) trail.shift();
  }
  if (hist.length && m.t < hist[hist.length - 1].t) hist.length = 0; // robot restarted
  hist.push({ t: m.t, cmd: m.wheel_cmd, meas: m.wheel_meas, err: m.tracking_error_m, twistErr: m.twist_error });
  while (hist.length > HIST_MAX || (hist.length && hist[0].t < m.t - HISTORY_S)) hist.shift();
  linkTableThrottled();
}

let linkTimer = 0;
function linkTableThrottled() {
  const now = performance.now();
  if (now - linkTimer > 250) { linkTimer = now; linkTable(); }
}

function addEvent(level, text, t) {
  const li = document.createElement('li');
  li.className = level;
  const s = document.createElement('span');
  s.className = 't';
  s.textContent = t == null ? new Date().toLocaleTimeString() : `${t.toFixed(2)} s`;
  li.append(s, document.createTextNode(text));
  const ol = $('events');
  ol.prepend(li);
  while (ol.children.length > EVENTS_MAX) ol.lastChild.remove();
}

// ---- e-stop: first, always ----
function estop() {
  // Sent even if the socket is still opening (then the server has no page yet: say so).
  if (!send({ type: 'estop' })) addEvent('error', 'e-stop NOT sent: the page is not connected to the console', null);
  releaseAll();
}
$('estop').addEventListener('pointerdown', (e) => { e.preventDefault(); estop(); });
$('estop').addEventListener('click', (e) => { if (e.detail === 0) estop(); }); // keyboard activation
window.addEventListener('keydown', (e) => {
  if (e.code === 'Space') { e.preventDefault(); e.stopImmediatePropagation(); if (!e.repeat) estop(); }
}, true);
$('clear').addEventListener('click', () => send({ type: 'clear' }));
$('take-control').addEventListener('click', () => send({ type: 'take_control' }));
$('stop').addEventListener('click', () => send({ type: 'stop' }));

// ---- teleop: keyboard and gamepad, dead-man held ----
const held = new Set();
let deadman = false;
let wasDriving = false;
const KEYS = {
  ArrowUp: [1, 0, 0], KeyW: [1, 0, 0], ArrowDown: [-1, 0, 0], KeyS: [-1, 0, 0],
  ArrowLeft: [0, 1, 0], KeyA: [0, 1, 0], ArrowRight: [0, -1, 0], KeyD: [0, -1, 0],
  KeyQ: [0, 0, 1], KeyE: [0, 0, -1],
};
function typing(e) { const t = e.target; return t && (t.tagName === 'INPUT' && t.type !== 'checkbox' && t.type !== 'file'); }
window.addEventListener('keydown', (e) => {
  if (typing(e)) return;
  if (e.key === 'Shift') deadman = true;
  if (KEYS[e.code]) { held.add(e.code); e.preventDefault(); }
});
window.addEventListener('keyup', (e) => {
  if (e.key === 'Shift') deadman = false;
  held.delete(e.code);
});
function releaseAll() { held.clear(); deadman = false; padRelease(); turn = 0; $('turn-left').classList.remove('on'); $('turn-right').classList.remove('on'); }
window.addEventListener('blur', releaseAll);
document.addEventListener('visibilitychange', () => { if (document.hidden) releaseAll(); });

// ---- touch teleop: holding the pad or a turn button is the dead-man; lifting stops ----
const padEl = $('touch-pad');
let padPointer = null;      // the pointer holding the pad
let padV = [0, 0];          // forward, left: fractions of --speed
let turn = 0;               // counter-clockwise: fraction of --turn
function padMove(e) {
  const r = padEl.getBoundingClientRect();
  const dz = (v) => (Math.abs(v) < 0.12 ? 0 : v);
  const fx = Math.max(-1, Math.min(1, (e.clientX - r.left - r.width / 2) / (r.width / 2)));
  const fy = Math.max(-1, Math.min(1, (e.clientY - r.top - r.height / 2) / (r.height / 2)));
  padV = [-dz(fy), -dz(fx)]; // screen up = forward (robot +x), screen left = robot +y
  $('touch-dot').style.transform = `translate(${fx * r.width / 2}px, ${fy * r.height / 2}px)`;
}
function padRelease() {
  padPointer = null; padV = [0, 0];
  padEl.classList.remove('on');
  $('touch-dot').style.transform = '';
}
padEl.addEventListener('pointerdown', (e) => {
  e.preventDefault();
  padPointer = e.pointerId;
  padEl.setPointerCapture(e.pointerId);
  padEl.classList.add('on');
  padMove(e);
});
padEl.addEventListener('pointermove', (e) => { if (e.pointerId === padPointer) padMove(e); });
for (const ev of ['pointerup', 'pointercancel', 'lostpointercapture']) {
  padEl.addEventListener(ev, (e) => { if (e.pointerId === padPointer) padRelease(); });
}
padEl.addEventListener('contextmenu', (e) => e.preventDefault());
for (const [id, dir] of [['turn-left', 1], ['turn-right', -1]]) {
  const b = $(id);
  b.addEventListener('pointerdown', (e) => { e.preventDefault(); b.setPointerCapture(e.pointerId); turn = dir; b.classList.add('on'); });
  for (const ev of ['pointerup', 'pointercancel', 'lostpointercapture']) {
    b.addEventListener(ev, () => { if (turn === dir) turn = 0; b.classList.remove('on'); });
  }
  b.addEventListener('contextmenu', (e) => e.preventDefault());
}

function gamepadAxes() {
  const pads = navigator.getGamepads ? navigator.getGamepads() : [];
  for (const p of pads) {
    if (!p || !p.connected) continue;
    $('gamepad').textContent = p.id.slice(0, 40);
    const dz = (v) => (Math.abs(v) < 0.15 ? 0 : v);
    if (p.buttons[1] && p.buttons[1].pressed) estop();
    const dm = (p.buttons[4] && p.buttons[4].pressed) || (p.buttons[6] && p.buttons[6].value > 0.5);
    return { dm, v: [-dz(p.axes[1] || 0), -dz(p.axes[0] || 0), -dz(p.axes[2] || 0)] };
  }
  return null;
}

function teleopTick() {
  const pad = gamepadAxes();
  let v = [0, 0, 0];
  for (const k of held) { const d = KEYS[k]; v = [v[0] + d[0], v[1] + d[1], v[2] + d[2]]; }
  let dm = deadman;
  if (pad && pad.dm) { dm = true; v = [v[0] + pad.v[0], v[1] + pad.v[1], v[2] + pad.v[2]]; }
  if (padPointer != null || turn !== 0) { dm = true; v = [v[0] + padV[0], v[1] + padV[1], v[2] + turn]; }
  v = v.map((a) => Math.max(-1, Math.min(1, a)));
  const d = $('deadman');
  d.textContent = dm ? 'dead-man held' : 'dead-man released';
  d.className = 'state ' + (dm ? 'on' : 'off');
  $('teleop-cmd').textContent = `${(v[0] * config.speed).toFixed(2)} m/s, ${(v[1] * config.speed).toFixed(2)} m/s, ${(v[2] * config.turn).toFixed(2)} rad/s`;
  if (viewOnly()) {
    d.textContent = `view only: ${holderName} holds the controls`;
    d.className = 'state off';
    wasDriving = false;
  } else if (dm) {
    send({ type: 'teleop', vx: v[0], vy: v[1], yaw: v[2] });
    wasDriving = true;
  } else if (wasDriving) {
    send({ type: 'stop' }); // released: zero command now (the server and the robot's watchdog stop it anyway)
    wasDriving = false;
  }
}
setInterval(teleopTick, 50);

// ---- recording to MCAP (written by the console, in its --record-dir) ----
let recording = false;
function recordState(m) {
  recording = m.on;
  $('record').textContent = m.on ? 'Stop recording' : 'Record MCAP';
  $('record').classList.toggle('rec', m.on);
  $('record-note').textContent = m.on ? `recording to ${m.path}` : 'not recording';
}
$('record').addEventListener('click', () => send({ type: 'record', on: !recording }));

// ---- plan upload ----
const MAX_PLAN_BYTES = 8 * 1024 * 1024 - 4096;
function loadPlanFile(f) {
  if (!f) return;
  if (f.size > MAX_PLAN_BYTES) { addEvent('error', `plan ${f.name}: ${f.size} bytes, more than the console takes`, null); return; }
  const r = new FileReader();
  r.onload = () => send({ type: 'plan', name: f.name, csv: String(r.result) });
  r.readAsText(f);
}
$('plan-upload').addEventListener('change', (e) => loadPlanFile(e.target.files[0]));
const drop = $('drop');
drop.addEventListener('dragover', (e) => { e.preventDefault(); drop.classList.add('over'); });
drop.addEventListener('dragleave', () => drop.classList.remove('over'));
drop.addEventListener('drop', (e) => { e.preventDefault(); drop.classList.remove('over'); loadPlanFile(e.dataTransfer.files[0]); });
// A plan that starts away from the robot (beyond the console's --start-tolerance, without
// "set pose") runs only after a second click: the robot would first drive itself to the start.
// No modal dialog: E-STOP stays usable while the page asks.
let armedUntil = 0;
function disarm() { armedUntil = 0; $('plan-run').textContent = 'Run plan'; $('plan-warning').hidden = true; }
$('set-pose').addEventListener('change', disarm);
$('plan-run').addEventListener('click', () => {
  const setPose = $('set-pose').checked;
  const tol = config.start_tolerance_m ?? 0.1;
  if (!setPose && plan && plan.points.length && last && performance.now() > armedUntil) {
    const p0 = plan.points[0];
    const d = Math.hypot(last.pose[0] - p0[0], last.pose[1] - p0[1]);
    if (d > tol) {
      armedUntil = performance.now() + 10000;
      $('plan-warning').hidden = false;
      $('plan-warning').textContent = `The robot is ${d.toFixed(2)} m from the plan's start (more than ${tol} m): it would first drive itself there. Click again within 10 s to drive anyway, or tick "set pose to the plan's start".`;
      $('plan-run').textContent = 'Drive anyway';
      return;
    }
  }
  disarm();
  send({ type: 'plan_run', set_pose: setPose });
});

function planInfo() {
  $('plan-info').textContent = `${plan.name}: ${plan.samples} samples, ${plan.duration_s.toFixed(1)} s, ${plan.length_m.toFixed(2)} m`;
  $('plan-run').disabled = viewOnly();
}
function planStatus(m) {
  planState = m.state;
  let s = m.state;
  const el = $('plan-state');
  if (m.state === 'running' && m.duration_s != null) {
    // Progress along the plan, in plan time (the robot's clock since it began the plan).
    const pc = m.duration_s > 0 ? Math.round(100 * m.elapsed_s / m.duration_s) : 100;
    s += ` ${m.elapsed_s.toFixed(1)} / ${m.duration_s.toFixed(1)} s (${pc} %)`;
    el.dataset.percent = pc;
  } else if (m.state === 'uploading' && m.len) {
    s += ` ${m.received}/${m.len} points`;
  }
  if (m.detail) s += ` — ${m.detail}`;
  el.textContent = s;
  $('plan-run').disabled = viewOnly() || !plan || m.state === 'uploading' || m.state === 'running';
}

// ---- drawing ----
function fitCanvas(c) {
  const dpr = window.devicePixelRatio || 1;
  const w = Math.round(c.clientWidth * dpr), h = Math.round(c.clientWidth * dpr * c.height / c.width);
  return { ctx: c.getContext('2d'), w: c.width, h: c.height, dpr, cw: w, ch: h };
}

function niceStep(span, n) {
  const raw = span / n, p = Math.pow(10, Math.floor(Math.log10(raw)));
  for (const m of [1, 2, 5, 10]) if (m * p >= raw) return m * p;
  return 10 * p;
}

function drawMap() {
  const c = $('map'), ctx = c.getContext('2d'), W = c.width, H = c.height;
  ctx.clearRect(0, 0, W, H);
  // View: everything of interest, at least 1 m across, equal scale on both axes.
  const pts = [];
  if (plan) for (const p of plan.points) pts.push(p);
  if (map && map.keep_in) for (const p of map.keep_in) pts.push(p);
  for (const p of trail) if (p) pts.push(p);
  if (last) pts.push(last.pose, last.reference);
  if (last && last.truth) pts.push(last.truth);
  let x0 = -0.5, x1 = 0.5, y0 = -0.5, y1 = 0.5;
  if (pts.length) {
    x0 = Math.min(...pts.map((p) => p[0])); x1 = Math.max(...pts.map((p) => p[0]));
    y0 = Math.min(...pts.map((p) => p[1])); y1 = Math.max(...pts.map((p) => p[1]));
  }
  const cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
  const span = Math.max(1, (x1 - x0) * 1.25, (y1 - y0) * 1.25 * W / H);
  const s = W / span; // px per m
  const X = (x) => W / 2 + (x - cx) * s, Y = (y) => H / 2 - (y - cy) * s;
  // Grid.
  const step = niceStep(span, 8);
  ctx.strokeStyle = '#eceef1'; ctx.lineWidth = 1; ctx.fillStyle = '#9ca3af'; ctx.font = '11px system-ui';
  const gx0 = Math.floor((cx - span / 2) / step) * step, gy0 = Math.floor((cy - span * H / W / 2) / step) * step;
  for (let g = gx0; g <= cx + span / 2; g += step) {
    ctx.beginPath(); ctx.moveTo(X(g), 0); ctx.lineTo(X(g), H); ctx.stroke();
    if (X(g) > 30 && X(g) < W - 40) ctx.fillText(`${+g.toFixed(3)}`, X(g) + 2, H - 4);
  }
  for (let g = gy0; g <= cy + span * H / W / 2; g += step) {
    ctx.beginPath(); ctx.moveTo(0, Y(g)); ctx.lineTo(W, Y(g)); ctx.stroke();
    if (Y(g) > 14 && Y(g) < H - 18) ctx.fillText(`${+g.toFixed(3)}`, 2, Y(g) - 2);
  }
  // World axes at the origin.
  ctx.strokeStyle = '#9ca3af'; ctx.lineWidth = 1.5;
  ctx.beginPath(); ctx.moveTo(X(0), Y(0)); ctx.lineTo(X(step), Y(0)); ctx.moveTo(X(0), Y(0)); ctx.lineTo(X(0), Y(step)); ctx.stroke();
  ctx.fillStyle = '#6b7280'; ctx.fillText('x', X(step) + 3, Y(0) + 4); ctx.fillText('y', X(0) - 4, Y(step) - 4);
  ctx.fillText(`grid ${+step.toFixed(3)} m`, W - 80, 14);
  // Map: the keep-in boundary and the keep-out shapes.
  if (map) {
    ctx.lineWidth = 1.5;
    if (map.keep_in) {
      ctx.strokeStyle = '#6b7280'; ctx.beginPath();
      map.keep_in.forEach((p, i) => (i ? ctx.lineTo(X(p[0]), Y(p[1])) : ctx.moveTo(X(p[0]), Y(p[1]))));
      ctx.closePath(); ctx.stroke();
    }
    ctx.fillStyle = 'rgba(185, 28, 28, 0.18)'; ctx.strokeStyle = 'rgba(185, 28, 28, 0.7)';
    for (const o of map.keep_out) {
      ctx.beginPath();
      if (o.circle) ctx.arc(X(o.circle[0]), Y(o.circle[1]), o.circle[2] * s, 0, 2 * Math.PI);
      else o.polygon.forEach((p, i) => (i ? ctx.lineTo(X(p[0]), Y(p[1])) : ctx.moveTo(X(p[0]), Y(p[1]))));
      ctx.closePath(); ctx.fill(); ctx.stroke();
    }
  }
  // Trail.
  if (trail.length > 1) {
    ctx.strokeStyle = 'rgba(13, 148, 136, 0.75)'; ctx.lineWidth = 4; ctx.beginPath();
    let pen = false;
    for (const p of trail) {
      if (!p) { pen = false; continue; }
      if (pen) ctx.lineTo(X(p[0]), Y(p[1])); else ctx.moveTo(X(p[0]), Y(p[1]));
      pen = true;
    }
    ctx.stroke();
  }
  // The simulated truth's trail: thin and dashed under the estimate's.
  if (truthTrail.length > 1) {
    ctx.strokeStyle = 'rgba(107, 114, 128, 0.9)'; ctx.lineWidth = 1.5; ctx.setLineDash([3, 3]); ctx.beginPath();
    truthTrail.forEach((p, i) => (i ? ctx.lineTo(X(p[0]), Y(p[1])) : ctx.moveTo(X(p[0]), Y(p[1]))));
    ctx.stroke(); ctx.setLineDash([]);
  }
  // Plan (over the trail, thinner: where they differ both show).
  if (plan && plan.points.length) {
    const running = planState === 'running' || planState === 'uploading' || planState === 'done';
    ctx.strokeStyle = running ? '#2563eb' : '#9333ea'; ctx.lineWidth = 1.5;
    ctx.setLineDash(running ? [] : [6, 4]);
    ctx.beginPath();
    plan.points.forEach((p, i) => (i ? ctx.lineTo(X(p[0]), Y(p[1])) : ctx.moveTo(X(p[0]), Y(p[1]))));
    ctx.stroke(); ctx.setLineDash([]);
    const p0 = plan.points[0];
    ctx.fillStyle = ctx.strokeStyle; ctx.beginPath(); ctx.arc(X(p0[0]), Y(p0[1]), 4, 0, 7); ctx.fill();
  }
  if (last) {
    if (last.mode === 'trajectory') {
      ctx.fillStyle = '#f59e0b'; ctx.beginPath(); ctx.arc(X(last.reference[0]), Y(last.reference[1]), 5, 0, 7); ctx.fill();
    }
    if (last.truth) drawRobot(ctx, X(last.truth[0]), Y(last.truth[1]), last.truth[2], Math.max(7, 0.035 * s), '#6b7280');
    drawRobot(ctx, X(last.pose[0]), Y(last.pose[1]), last.pose[2], Math.max(7, 0.035 * s), last.mode === 'estop' ? '#b91c1c' : '#111827');
  }
}

function drawRobot(ctx, px, py, h, r, color) {
  ctx.save(); ctx.translate(px, py); ctx.rotate(-h);
  ctx.fillStyle = color + '22'; ctx.strokeStyle = color; ctx.lineWidth = 2;
  ctx.beginPath(); ctx.arc(0, 0, r, 0, 7); ctx.fill(); ctx.stroke();
  ctx.beginPath(); ctx.moveTo(0, 0); ctx.lineTo(r * 1.5, 0); ctx.stroke(); // heading: robot +x
  ctx.beginPath(); ctx.moveTo(r * 1.5, 0); ctx.lineTo(r * 1.1, -r * 0.3); ctx.lineTo(r * 1.1, r * 0.3); ctx.closePath(); ctx.fillStyle = color; ctx.fill();
  ctx.restore();
}

const WHEEL_COLORS = ['#2563eb', '#dc2626', '#16a34a', '#9333ea', '#ea580c', '#0891b2', '#ca8a04', '#db2777'];

function plotFrame(c, series, yLabel) {
  const ctx = c.getContext('2d'), W = c.width, H = c.height;
  ctx.clearRect(0, 0, W, H);
  const L = 48, R = 8, T = 8, B = 22;
  // The window: the last HISTORY_S of robot time (from 0 while the robot is younger).
  const tEnd = Math.max(HISTORY_S, hist.length ? hist[hist.length - 1].t : 0), t0 = tEnd - HISTORY_S;
  let lo = Infinity, hi = -Infinity;
  for (const s of series) for (const [, v] of s.data) { if (v < lo) lo = v; if (v > hi) hi = v; }
  if (!isFinite(lo)) { lo = -1; hi = 1; }
  if (hi - lo < 1e-3) { hi += 0.5; lo -= 0.5; }
  const pad = (hi - lo) * 0.08; lo -= pad; hi += pad;
  const X = (t) => L + (t - t0) / HISTORY_S * (W - L - R), Y = (v) => T + (hi - v) / (hi - lo) * (H - T - B);
  ctx.strokeStyle = '#eceef1'; ctx.fillStyle = '#6b7280'; ctx.font = '11px system-ui'; ctx.lineWidth = 1;
  const ys = niceStep(hi - lo, 6);
  for (let v = Math.ceil(lo / ys) * ys; v <= hi; v += ys) {
    ctx.beginPath(); ctx.moveTo(L, Y(v)); ctx.lineTo(W - R, Y(v)); ctx.stroke();
    ctx.fillText(`${+v.toFixed(3)}`, 4, Y(v) + 4);
  }
  for (let t = Math.ceil(t0 / 5) * 5; t <= tEnd; t += 5) {
    ctx.beginPath(); ctx.moveTo(X(t), T); ctx.lineTo(X(t), H - B); ctx.stroke();
    ctx.fillText(`${t.toFixed(0)} s`, X(t) - 8, H - 6);
  }
  if (lo < 0 && hi > 0) { ctx.strokeStyle = '#c5cad3'; ctx.beginPath(); ctx.moveTo(L, Y(0)); ctx.lineTo(W - R, Y(0)); ctx.stroke(); }
  for (const s of series) {
    ctx.strokeStyle = s.color; ctx.fillStyle = s.color; ctx.lineWidth = 1.6;
    if (s.dots) {
      for (const [t, v] of s.data) ctx.fillRect(X(t) - 1.2, Y(v) - 1.2, 2.4, 2.4);
      continue;
    }
    ctx.setLineDash(s.dash || []);
    ctx.beginPath();
    let pen = false;
    for (const [t, v] of s.data) {
      if (v == null) { pen = false; continue; }
      if (pen) ctx.lineTo(X(t), Y(v)); else ctx.moveTo(X(t), Y(v));
      pen = true;
    }
    ctx.stroke(); ctx.setLineDash([]);
  }
  ctx.fillStyle = '#374151';
  let lx = L + 6;
  for (const s of series) if (s.label) { ctx.fillStyle = s.color; ctx.fillText(s.label, lx, T + 12); lx += ctx.measureText(s.label).width + 12; }
}

function drawPlots() {
  const n = last ? last.wheels : 0;
  const series = [];
  for (let i = 0; i < n; i++) {
    const color = WHEEL_COLORS[i % WHEEL_COLORS.length];
    series.push({ color, label: `w${i + 1}`, data: hist.map((h) => [h.t, h.cmd ? h.cmd[i] : null]) });
    series.push({ color, dots: true, data: hist.filter((h) => h.meas).map((h) => [h.t, h.meas[i]]) });
  }
  plotFrame($('wheels'), series);
  plotFrame($('error'), [
    { color: '#f59e0b', label: 'position error (m)', data: hist.map((h) => [h.t, h.err]) },
    { color: '#6b7280', label: 'speed error (m/s)', dash: [5, 4], data: hist.map((h) => [h.t, h.twistErr]) },
  ]);
}

function frame() {
  drawMap();
  drawPlots();
  requestAnimationFrame(frame);
}

connect();
requestAnimationFrame(frame);
