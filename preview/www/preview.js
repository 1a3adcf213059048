/* mocap-preview's page: the events from /events drawn as camera views, a
 * 3D skeleton, the status and a plot.  Everything comes from this origin
 * (the server's Content-Security-Policy says so too). */
'use strict';

/* The token for state changes: given once as ?token=..., kept for this
 * tab only and taken out of the address bar. */
const params = new URLSearchParams(location.search);
if (params.get('token')) {
  sessionStorage.setItem('mocap-token', params.get('token'));
  history.replaceState(null, '', location.pathname);
}
const token = sessionStorage.getItem('mocap-token') || '';

const $ = (id) => document.getElementById(id);
/* Confidence in ten steps: the page changes only when a step does (each
 * change costs the browser a repaint). */
const confColour = (c) => `hsl(${12 * Math.round(10 * Math.max(0, Math.min(1, c)))}, 75%, 50%)`;

/* ---- camera views ---- */
const camViews = [];
function onFrame(d) {
  let v = camViews[d.camera];
  if (!v) {
    const box = document.createElement('div');
    box.className = 'cam';
    const img = document.createElement('img');
    img.id = 'cam' + d.camera;
    img.alt = d.name;
    const label = document.createElement('span');
    label.textContent = d.name;
    box.append(img, label);
    $('cams').append(box);
    v = camViews[d.camera] = { img };
  }
  v.img.width = d.width;
  v.img.height = d.height;
  v.img.src = 'data:image/jpeg;base64,' + d.jpeg;
  v.img.dataset.seq = d.seq;
}

/* ---- the 3D view: three.js (WebGL), or a plain canvas where the browser
 * has no WebGL (a headless browser without a GPU, say) ---- */
const view = { joints: null, rigIsWorld: false };
function toView(p) {
  /* Three.js is y-up.  A head rig's frame is a camera's (y down, z
   * forward): turned 180 degrees about x.  A world frame is z-up. */
  return view.rigIsWorld ? [p[0], p[2], -p[1]] : [p[0], -p[1], -p[2]];
}

function makeWebGLView(el) {
  /* No antialiasing: without a GPU (SwiftShader) it is most of the page's CPU. */
  const renderer = new THREE.WebGLRenderer({ antialias: false });
  renderer.setClearColor(0x0e1014);
  el.append(renderer.domElement);
  const scene = new THREE.Scene();
  const camera = new THREE.PerspectiveCamera(45, 1, 0.01, 100);
  camera.position.set(1.8, 0.6, 2.4);
  const controls = new THREE.OrbitControls(camera, renderer.domElement);
  scene.add(new THREE.GridHelper(4, 8, 0x555555, 0x333333));
  scene.add(new THREE.AxesHelper(0.3));
  const bones = new THREE.LineSegments(new THREE.BufferGeometry(), new THREE.LineBasicMaterial({ color: 0xffe640 }));
  scene.add(bones);
  const balls = [];
  const ballGeom = new THREE.SphereBufferGeometry(0.03, 12, 8);
  let fitted = false;
  function resize() {
    const w = el.clientWidth, h = el.clientHeight;
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(1, h);
    camera.updateProjectionMatrix();
  }
  window.addEventListener('resize', resize);
  resize();
  return {
    kind: 'webgl',
    draw(joints) {
      const pts = joints.map((j) => toView(j.p));
      const seg = [];
      joints.forEach((j, i) => { if (j.parent >= 0) seg.push(...pts[j.parent], ...pts[i]); });
      bones.geometry.setAttribute('position', new THREE.Float32BufferAttribute(seg, 3));
      while (balls.length < joints.length) {
        const m = new THREE.Mesh(ballGeom, new THREE.MeshBasicMaterial());
        scene.add(m);
        balls.push(m);
      }
      joints.forEach((j, i) => {
        balls[i].position.set(...pts[i]);
        balls[i].material.color.set(confColour(j.c));
        balls[i].visible = true;
      });
      for (let i = joints.length; i < balls.length; i++) balls[i].visible = false;
      if (!fitted && pts.length) {
        /* Look at the body once; then the user's orbit stays. */
        const c = pts.reduce((a, p) => [a[0] + p[0], a[1] + p[1], a[2] + p[2]], [0, 0, 0]).map((v) => v / pts.length);
        controls.target.set(...c);
        camera.position.set(c[0] + 1.6, c[1] + 0.5, c[2] + 2.2);
        controls.update();
        fitted = true;
      }
      renderer.render(scene, camera);
    },
    redraw() { renderer.render(scene, camera); },
  };
}

function make2DView(el) {
  const canvas = document.createElement('canvas');
  el.append(canvas);
  const ctx = canvas.getContext('2d');
  let yaw = 0.6;
  return {
    kind: '2d',
    draw(joints) {
      canvas.width = el.clientWidth;
      canvas.height = el.clientHeight;
      ctx.fillStyle = '#0e1014';
      ctx.fillRect(0, 0, canvas.width, canvas.height);
      if (!joints.length) return;
      const pts = joints.map((j) => toView(j.p));
      const c = pts.reduce((a, p) => [a[0] + p[0], a[1] + p[1], a[2] + p[2]], [0, 0, 0]).map((v) => v / pts.length);
      const s = Math.min(canvas.width, canvas.height) / 2.4;
      const proj = (p) => {
        const x = p[0] - c[0], y = p[1] - c[1], z = p[2] - c[2];
        return [canvas.width / 2 + s * (x * Math.cos(yaw) + z * Math.sin(yaw)), canvas.height / 2 - s * y];
      };
      ctx.lineWidth = 3;
      ctx.strokeStyle = '#ffe640';
      joints.forEach((j, i) => {
        if (j.parent < 0) return;
        const a = proj(pts[j.parent]), b = proj(pts[i]);
        ctx.beginPath(); ctx.moveTo(a[0], a[1]); ctx.lineTo(b[0], b[1]); ctx.stroke();
      });
      joints.forEach((j, i) => {
        const a = proj(pts[i]);
        ctx.fillStyle = confColour(j.c);
        ctx.beginPath(); ctx.arc(a[0], a[1], 5, 0, 2 * Math.PI); ctx.fill();
      });
    },
    redraw() {},
  };
}

function makeView() {
  const el = $('view3d');
  try {
    if (window.THREE && document.createElement('canvas').getContext('webgl')) return makeWebGLView(el);
  } catch (e) { /* no WebGL: the plain canvas below */ }
  return make2DView(el);
}
const view3d = makeView();
document.body.dataset.view = view3d.kind;

/* ---- skeleton and joints ---- */
let jointCells = [];
function onSkeleton(d) {
  view.rigIsWorld = d.rig_is_world || d.space === 'world';
  view3d.draw(d.joints);
  const box = $('joints');
  if (jointCells.length !== d.joints.length) {
    box.textContent = '';
    jointCells = d.joints.map((j) => {
      const e = document.createElement('div');
      e.className = 'joint';
      e.textContent = j.name;
      box.append(e);
      return e;
    });
  }
  d.joints.forEach((j, i) => {
    const colour = confColour(j.c);
    if (jointCells[i].dataset.colour !== colour) {
      jointCells[i].dataset.colour = colour;
      jointCells[i].style.background = colour;
      jointCells[i].title = `${j.name}: confidence ${j.c.toFixed(1)}`;
    }
  });
  setBadge($('tracker'), 'tracker: ' + d.state, { ok: 'ok', uncertain: 'warn', lost: 'bad' }[d.state] || 'off');
}

/* ---- status ---- */
function setBadge(el, text, kind) {
  if (el.textContent !== text) el.textContent = text;
  if (el.className !== 'badge ' + kind) el.className = 'badge ' + kind;
}

function onStatus(d) {
  setBadge($('conn'), d.connected ? 'connected' : 'no daemon', d.connected ? 'ok' : 'bad');
  $('conn').title = d.message;
  const s = d.daemon;
  const canControl = d.connected && d.can_record && token !== '';
  $('recstart').hidden = $('recstop').hidden = $('reload').hidden = $('takename').hidden = !canControl;
  if (d.connected && d.can_record && token === '') $('ctlmsg').textContent = 'open the address with ?token=... to control';
  const body = $('camtable').tBodies[0];
  body.textContent = '';
  if (s) {
    setBadge($('recstate'), s.recording ? 'recording' : 'not recording', s.recording ? 'rec' : 'off');
    $('recstate').title = d.record;
    $('recstart').disabled = s.recording;
    $('recstop').disabled = !s.recording;
    for (const c of s.cameras) {
      const tr = body.insertRow();
      [c.name, c.state, c.fps === null ? '-' : c.fps.toFixed(1), c.drops].forEach((v) => { tr.insertCell().textContent = v; });
    }
    const f = (v) => (v === null || v === undefined ? '-' : v.toFixed(1));
    $('tracking').textContent = `tracker ${s.tracker}, ${f(s.publish_fps)} fps, tracking ${f(s.track_ms_mean)} ms mean` +
      `, ${f(s.track_ms_max)} max` + (s.track_ms_p99 !== undefined ? `, ${f(s.track_ms_p99)} p99` : '') +
      `, ${s.frames_dropped} dropped, ${s.clients} clients`;
    if (!s.recording && s.tracker) setBadge($('tracker'), 'tracker: ' + s.tracker,
      { ok: 'ok', uncertain: 'warn', lost: 'bad', initialising: 'warn' }[s.tracker] || 'off');
  } else {
    setBadge($('recstate'), '', 'off');
    $('tracking').textContent = d.message;
  }
  plot(d.history);
}

/* Tracking time (left scale, ms) and mean confidence (0..1) over the last minute. */
function plot(h) {
  const cv = $('plot'), ctx = cv.getContext('2d');
  ctx.fillStyle = '#101216';
  ctx.fillRect(0, 0, cv.width, cv.height);
  if (!h || !h.t.length) return;
  const t1 = h.t[h.t.length - 1], t0 = t1 - 60;
  const maxMs = Math.max(1, ...h.track_ms.filter((v) => v !== null)) * 1.1;
  const x = (t) => ((t - t0) / 60) * (cv.width - 40) + 30;
  const line = (vals, scale, colour) => {
    ctx.strokeStyle = colour;
    ctx.lineWidth = 2;
    ctx.beginPath();
    let pen = false;
    vals.forEach((v, i) => {
      if (v === null) { pen = false; return; }
      const px = x(h.t[i]), py = cv.height - 10 - (v / scale) * (cv.height - 20);
      if (pen) ctx.lineTo(px, py); else ctx.moveTo(px, py);
      pen = true;
    });
    ctx.stroke();
  };
  line(h.track_ms, maxMs, '#ffb300');
  line(h.confidence, 1, '#4fc3f7');
  ctx.fillStyle = '#888';
  ctx.font = '10px sans-serif';
  ctx.fillText(maxMs.toFixed(0) + ' ms', 2, 12);
  ctx.fillText('0', 2, cv.height - 8);
}

/* ---- controls ---- */
async function control(path) {
  $('ctlmsg').textContent = '...';
  try {
    const r = await fetch(path, { method: 'POST', headers: { 'X-Mocap-Token': token } });
    const text = await r.text();
    let msg = text;
    try { msg = JSON.parse(text).message || r.statusText; } catch (e) { /* plain text */ }
    $('ctlmsg').textContent = (r.ok ? '' : r.status + ': ') + msg;
  } catch (e) {
    $('ctlmsg').textContent = 'request failed: ' + e;
  }
}
$('recstart').onclick = () => {
  const name = $('takename').value.trim();
  control('/api/record/start' + (name ? '?name=' + encodeURIComponent(name) : ''));
};
$('recstop').onclick = () => control('/api/record/stop');
$('reload').onclick = () => control('/api/reload');

/* ---- the event stream (the browser reconnects by itself) ---- */
const events = new EventSource('events');
events.addEventListener('status', (e) => onStatus(JSON.parse(e.data)));
events.addEventListener('skeleton', (e) => onSkeleton(JSON.parse(e.data)));
events.addEventListener('frame', (e) => onFrame(JSON.parse(e.data)));
events.onerror = () => setBadge($('conn'), 'preview server gone', 'bad');
events.onopen = () => setBadge($('conn'), 'connected', 'ok');
