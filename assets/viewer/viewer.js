// drumsim viewer: the render's SONG.glb (drummer, sticks and kit, with the motion as its
// animation) played in step with SONG.wav. The audio element is the clock: every frame the
// animation is set to the audio's time, so picture and sound cannot drift apart. Each
// contact of SONG.contacts.json lights the piece it struck.
//
// Query options: ?transparent=1 (no background or floor, no controls: an OBS browser
// source), ?ui=0 / ?ui=1 (hide / show the controls), ?view=audience|seat|top, ?follow=1,
// ?sticking=1, ?autoplay=1, ?t=SECONDS (start there).
//
// Live (`drumsim live --view`, info.json has "live": true): no sound or animation here; the
// pose of every frame comes over the WebSocket /live at 60 frames a second (bones, face,
// the hi-hat's top cymbal and the kick beater, the strikes shown in it), and the page
// reconnects by itself when the stream goes.
//
// window.drumsim is the page's state for tests and scripts: ready, errors, animTime,
// seek(t), play(), pause(), frameStats(), project(name), setVisible(name, on), litLevel(id),
// live (live mode: received, connects, arrivals, log), and three: { THREE, scene, renderer,
// camera, controls } for scripts that go further.

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { RoomEnvironment } from 'three/addons/environments/RoomEnvironment.js';

const params = new URLSearchParams(location.search);
const transparent = params.get('transparent') === '1';
const showUi = params.has('ui') ? params.get('ui') !== '0' : !transparent;
const api = (window.drumsim = { ready: false, errors: [], animTime: 0, frames: 0 });
window.addEventListener('error', (e) => api.errors.push(String(e.message || e)));
window.addEventListener('unhandledrejection', (e) => api.errors.push(String(e.reason)));
if (!showUi) document.body.classList.add('bare');

const $ = (id) => document.getElementById(id);
const audio = $('audio');

// A software renderer (SwiftShader: headless Chromium, machines without a GPU) draws
// without multisampling at one pixel per CSS pixel, to hold the frame rate.
function glRenderer() {
  try {
    const gl = document.createElement('canvas').getContext('webgl2');
    const ext = gl && gl.getExtension('WEBGL_debug_renderer_info');
    return ext ? gl.getParameter(ext.UNMASKED_RENDERER_WEBGL) : '';
  } catch (e) {
    return '';
  }
}
api.renderer = glRenderer();
const softwareRendering = () => /swiftshader|llvmpipe|software/i.test(api.renderer);
const software = params.has('software') ? params.get('software') === '1' : softwareRendering();
const renderer = new THREE.WebGLRenderer({ antialias: !software, alpha: transparent });
const fullRatio = software ? 1 : Math.min(window.devicePixelRatio || 1, 2);
renderer.setPixelRatio(fullRatio);
renderer.setSize(window.innerWidth, window.innerHeight);

// Drawing scale (?scale=auto, the default, or a fixed 0.25-1): with a software renderer the
// page draws at a lower resolution, upscaled by the browser, while its frames come slower
// than the display's (a dynamic resolution, as games do): where a GPU draws every pixel at
// the display's rate, a CPU drawing a 1280x720 page often cannot. Every 30 frames it looks
// at how many missed the display's refresh (an interval over 1.5 times the shortest one
// seen); more than 3 of 30 lowers the scale a step (x0.85, down to 0.5); 5 s without a
// miss tries a step back up, and a step that failed is tried again only after twice as long.
const scaleParam = params.get('scale') || 'auto';
const scaling = {
  auto: software && scaleParam === 'auto' && params.get('video') !== '1',
  scale: scaleParam === 'auto' ? 1 : Math.min(1, Math.max(0.25, parseFloat(scaleParam) || 1)),
  refresh: Infinity, intervals: [], calm: 0, waitUp: 300, trying: false, tried: 0,
};
function applyScale(scale) {
  scaling.scale = scale;
  renderer.setPixelRatio(fullRatio * scale);
  renderer.setSize(window.innerWidth, window.innerHeight);
  scaling.intervals.length = 0;
}
if (scaling.scale !== 1) applyScale(scaling.scale);
function adaptScale(interval) {
  scaling.refresh = Math.max(4, Math.min(scaling.refresh, interval));
  scaling.intervals.push(interval);
  if (scaling.intervals.length < 30) return;
  const missed = scaling.intervals.filter((d) => d > 1.5 * scaling.refresh).length;
  scaling.intervals.length = 0;
  if (missed > 3 && scaling.scale > 0.5) {
    // A step up that fails within 4 checks is not tried again soon.
    if (scaling.trying) scaling.waitUp = Math.min(2 * scaling.waitUp, 3600);
    scaling.trying = false;
    scaling.calm = 0;
    applyScale(Math.max(0.5, scaling.scale * 0.85));
    return;
  }
  if (scaling.trying && ++scaling.tried >= 4) {
    scaling.trying = false;
    scaling.waitUp = 300;
  }
  if (missed === 0 && scaling.scale < 1) {
    scaling.calm += 30;
    if (scaling.calm >= scaling.waitUp) {
      scaling.calm = 0;
      scaling.trying = true;
      scaling.tried = 0;
      applyScale(Math.min(1, scaling.scale / 0.85));
    }
  } else scaling.calm = 0;
}
if (transparent) renderer.setClearColor(0x000000, 0);
$('stage').appendChild(renderer.domElement);

const scene = new THREE.Scene();
if (!transparent) scene.background = new THREE.Color(0x1d2129);
// Metals (cymbals, chrome) need something to reflect.
if (!software) {
  const pmrem = new THREE.PMREMGenerator(renderer);
  scene.environment = pmrem.fromScene(new RoomEnvironment(), 0.04).texture;
  scene.environmentIntensity = 0.6;
}
scene.add(new THREE.HemisphereLight(0xf4f1ea, 0x3a3530, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 2.2);
sun.position.set(1.5, 4, 3);
scene.add(sun);
const back = new THREE.DirectionalLight(0xb8c8ff, 0.8);
back.position.set(-2, 2.5, -2);
scene.add(back);
if (!transparent) {
  const floor = new THREE.Mesh(new THREE.CircleGeometry(3.5, 64), new THREE.MeshLambertMaterial({ color: 0x3b3f47 }));
  floor.rotation.x = -Math.PI / 2;
  floor.position.y = -0.001;
  scene.add(floor);
}

const camera = new THREE.PerspectiveCamera(38, window.innerWidth / window.innerHeight, 0.03, 60);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;

// glTF frame: Y up, the drummer on the stool at the origin facing +Z, the kit in front.
const VIEWS = {
  audience: { position: [0.7, 1.95, 3.5], target: [0, 0.72, 0.25] },
  seat: { position: [0.28, 1.9, -0.38], target: [0, 0.66, 0.62] },
  top: { position: [0, 3.4, 0.36], target: [0, 0.4, 0.35] },
};
let follow = params.get('follow') === '1' || params.get('view') === 'follow';
let sticking = params.get('sticking') === '1';

function setView(name) {
  const v = VIEWS[name] || VIEWS.audience;
  camera.position.fromArray(v.position);
  controls.target.fromArray(v.target);
  camera.lookAt(controls.target);
  controls.update();
  document.querySelectorAll('[data-view]').forEach((b) => b.classList.toggle('active', b.dataset.view === name));
}

function showMessage(text) {
  const m = $('message');
  m.textContent = text;
  m.hidden = false;
}

// Colours of a lit piece: warm white, or by limb (left hand, right hand, right foot,
// left foot) when the sticking is shown.
const FLASH = new THREE.Color(1.0, 0.5, 0.08);
const LIMB = [new THREE.Color(0.3, 0.6, 1.0), new THREE.Color(1.0, 0.35, 0.3), new THREE.Color(0.35, 0.85, 0.42), new THREE.Color(0.78, 0.49, 1.0)];
const FLASH_S = 0.16;

let mixer = null;
let duration = 0;
const pieces = new Map(); // id -> { mesh, times: [], limbs: [], levels: [], level }

function lastAtOrBefore(times, t) {
  let lo = 0, hi = times.length - 1, best = -1;
  while (lo <= hi) {
    const mid = (lo + hi) >> 1;
    if (times[mid] <= t) { best = mid; lo = mid + 1; } else hi = mid - 1;
  }
  return best;
}

function updateLights(t) {
  for (const p of pieces.values()) {
    const k = lastAtOrBefore(p.times, t + 1e-4);
    let level = 0;
    if (k >= 0) level = p.levels[k] * Math.exp(-(t - p.times[k]) / FLASH_S);
    if (level < 0.01) level = 0;
    p.level = level;
    // The struck surface takes the flash's colour (it would wash out to white if only
    // made to glow).
    const flash = sticking && k >= 0 ? LIMB[p.limbs[k]] || FLASH : FLASH;
    const m = p.mesh.material;
    m.color.copy(p.base).lerp(flash, 0.8 * level);
    m.emissive.copy(flash);
    m.emissiveIntensity = 0.9 * level;
  }
}

// The follow camera: swings slowly around the kit and leans toward what was just played.
const followTarget = new THREE.Vector3(0, 0.8, 0.35);
function updateFollow(t) {
  const want = new THREE.Vector3(0, 0.8, 0.35);
  let weight = 1;
  for (const p of pieces.values()) {
    if (p.level > 0.05) {
      want.addScaledVector(p.centre, p.level);
      weight += p.level;
    }
  }
  want.multiplyScalar(1 / weight);
  followTarget.lerp(want, 0.04);
  const azimuth = 0.45 * Math.sin(t * 0.11) + 0.12;
  const height = 1.35 + 0.25 * Math.sin(t * 0.07);
  const distance = 2.7;
  const goal = new THREE.Vector3(followTarget.x + distance * Math.sin(azimuth), height, followTarget.z + distance * Math.cos(azimuth));
  camera.position.lerp(goal, 0.05);
  controls.target.copy(followTarget);
  camera.lookAt(followTarget);
}

function clockText(t) {
  const m = Math.floor(t / 60);
  const s = (t - 60 * m).toFixed(2).padStart(5, '0');
  return `${m}:${s}`;
}

let scrubbing = false;
const frameTimes = [];
let lastFrame = 0;
let fpsShownAt = 0;

function setTime(t) {
  const clamped = Math.max(0, Math.min(t, duration));
  if (mixer) mixer.setTime(clamped);
  api.animTime = clamped;
  updateLights(clamped);
}

function frame(now) {
  requestAnimationFrame(frame);
  if (lastFrame) {
    frameTimes.push(now - lastFrame);
    if (frameTimes.length > 1200) frameTimes.shift();
    if (scaling.auto) adaptScale(now - lastFrame);
  }
  lastFrame = now;
  const t = live ? liveClock() : audio.currentTime;
  if (live) {
    api.animTime = t;
    updateLights(t);
  } else setTime(t);
  if (follow) updateFollow(t);
  else controls.update();
  if (live) $('clock').textContent = live.socket && live.socket.readyState === 1 ? 'live' : 'connecting';
  else {
    if (!scrubbing && duration > 0) $('scrub').value = String(t / duration);
    $('clock').textContent = `${clockText(t)} / ${clockText(duration)}`;
  }
  if (now - fpsShownAt > 1000 && frameTimes.length > 10) {
    fpsShownAt = now;
    const s = api.frameStats();
    $('fps').textContent = `${s.fps.toFixed(0)} fps`;
  }
  renderer.render(scene, camera);
  api.frames += 1;
}

api.frameStats = () => {
  const sorted = [...frameTimes].sort((a, b) => a - b);
  const n = sorted.length;
  const mean = n ? sorted.reduce((a, b) => a + b, 0) / n : 0;
  return { frames: n, mean_ms: mean, p95_ms: n ? sorted[Math.floor(0.95 * (n - 1))] : 0, max_ms: n ? sorted[n - 1] : 0, fps: mean ? 1000 / mean : 0, scale: scaling.scale };
};
api.resetFrameStats = () => { frameTimes.length = 0; lastFrame = 0; };

// Seek and resolve once the audio has moved there and the picture shows it.
api.seek = (t) => new Promise((resolve) => {
  const done = () => {
    setTime(audio.currentTime);
    renderer.render(scene, camera);
    requestAnimationFrame(() => requestAnimationFrame(() => resolve(audio.currentTime)));
  };
  audio.addEventListener('seeked', done, { once: true });
  audio.currentTime = t;
});
api.play = () => audio.play();
api.pause = () => audio.pause();
api.audioTime = () => audio.currentTime;
api.audioDuration = () => duration;
// The dynamic drawing scale: its state, and intervals (ms) fed to it as if frames had come so.
api.scaling = scaling;
api.feedFrameIntervals = (list) => { list.forEach(adaptScale); return scaling.scale; };
api.setView = setView;
api.setFollow = (on) => { follow = on; $('follow').checked = on; };
api.setSticking = (on) => { sticking = on; $('sticking').checked = on; $('legend').hidden = !on; };
api.litLevel = (id) => (pieces.get(id) ? pieces.get(id).level : null);
// The CSS-pixel position of a named object's centre (a piece id, 'drummer', a bone name).
api.project = (name) => {
  const o = scene.getObjectByName(THREE.PropertyBinding.sanitizeNodeName(name));
  if (!o) return null;
  o.updateWorldMatrix(true, false);
  const p = new THREE.Vector3();
  if (o.isMesh && !o.isSkinnedMesh) {
    o.geometry.computeBoundingSphere();
    p.copy(o.geometry.boundingSphere.center).applyMatrix4(o.matrixWorld);
  } else o.getWorldPosition(p);
  p.project(camera);
  const r = renderer.domElement.getBoundingClientRect();
  return { x: (p.x * 0.5 + 0.5) * r.width, y: (-p.y * 0.5 + 0.5) * r.height };
};
api.setVisible = (name, on) => {
  const o = scene.getObjectByName(THREE.PropertyBinding.sanitizeNodeName(name));
  if (o) o.visible = on;
  renderer.render(scene, camera);
  return !!o;
};
api.render = () => renderer.render(scene, camera);
api.three = { THREE, scene, renderer, camera, controls };

// Live mode: the newest frame's shown time, run on by the page's clock between frames.
let live = null;
function liveClock() {
  if (!live.last) return 0;
  return live.last.s + (performance.now() - live.lastArrival) / 1000;
}

function litPiece(id) {
  let p = pieces.get(id);
  if (p) return p;
  const mesh = scene.getObjectByName(THREE.PropertyBinding.sanitizeNodeName(id));
  if (!mesh || !mesh.isMesh) return null;
  mesh.material = mesh.material.clone();
  mesh.geometry.computeBoundingSphere();
  const centre = mesh.geometry.boundingSphere.center.clone().applyMatrix4(mesh.matrixWorld);
  p = { mesh, centre, base: mesh.material.color.clone(), times: [], limbs: [], levels: [], level: 0 };
  pieces.set(id, p);
  return p;
}

function applyLiveFrame(msg) {
  const now = performance.now();
  live.received += 1;
  live.arrivals.push(now);
  if (live.arrivals.length > 2400) live.arrivals.shift();
  live.log.push({ arrival: now, t: msg.t, s: msg.s, tips: msg.tips, strikes: msg.strikes });
  if (live.log.length > 2400) live.log.shift();
  live.last = msg;
  live.lastArrival = now;
  msg.bones.forEach((q, i) => { if (live.bones[i]) live.bones[i].quaternion.set(q[0], q[1], q[2], q[3]); });
  if (live.bones[0]) live.bones[0].position.set(msg.root[0], msg.root[1], msg.root[2]);
  for (const m of live.morphs) msg.face.forEach((w, k) => { m.morphTargetInfluences[k] = w; });
  for (const n of msg.nodes) {
    if (!live.nodes.has(n.name)) live.nodes.set(n.name, scene.getObjectByName(THREE.PropertyBinding.sanitizeNodeName(n.name)));
    const o = live.nodes.get(n.name);
    if (!o) continue;
    if (n.t) o.position.set(n.t[0], n.t[1], n.t[2]);
    if (n.r) o.quaternion.set(n.r[0], n.r[1], n.r[2], n.r[3]);
  }
  for (const strike of msg.strikes) {
    const p = litPiece(strike.piece);
    if (!p) continue;
    p.times.push(msg.s);
    p.limbs.push(-1);
    p.levels.push(Math.min(1, Math.max(0.35, strike.velocity / 110)));
    if (p.times.length > 64) { p.times.shift(); p.limbs.shift(); p.levels.shift(); }
  }
}

function connectLive() {
  const socket = new WebSocket(`ws://${location.host}/live`);
  live.socket = socket;
  socket.onopen = () => {
    live.connects += 1;
    $('message').hidden = true;
    // A new session's clock starts again: forget the strikes of the one before.
    for (const p of pieces.values()) { p.times.length = 0; p.limbs.length = 0; p.levels.length = 0; }
  };
  socket.onmessage = (e) => applyLiveFrame(JSON.parse(e.data));
  // drumsim stopped or restarted: say so and try again every second.
  socket.onclose = () => {
    if (live.connects > 0) showMessage('drumsim live is not running; reconnecting…');
    setTimeout(connectLive, 1000);
  };
}

async function loadLive(info) {
  $('title').textContent = `live  ·  kit ${info.kit}  ·  strokes land ${Math.round(info.lookahead_ms)} ms after their notes`;
  document.title = 'drumsim · live';
  for (const id of ['play', 'scrub', 'speed']) $(id).hidden = true;
  const gltf = await new GLTFLoader().loadAsync('/song.glb');
  scene.add(gltf.scene);
  prepareMeshes(gltf.scene);
  const byName = (n) => scene.getObjectByName(THREE.PropertyBinding.sanitizeNodeName(n));
  live = { received: 0, connects: 0, arrivals: [], log: [], last: null, lastArrival: 0, socket: null,
    bones: info.bones.map(byName), morphs: [], nodes: new Map() };
  gltf.scene.traverse((o) => { if (o.isMesh && o.morphTargetInfluences && o.morphTargetInfluences.length) live.morphs.push(o); });
  for (const id of info.pieces) litPiece(id);
  api.info = info;
  api.live = live;
  setView(params.get('view') || 'audience');
  api.setFollow(follow);
  api.setSticking(false);
  connectLive();
  requestAnimationFrame(frame);
  api.ready = true;
}

// Video mode (`drumsim video`, ?video=1&w=&h=&fps=&frames=): draw every frame of the song at
// its time, read its pixels back and send them to drumsim over the WebSocket /frames, at
// most AHEAD frames ahead of the ones drumsim has taken.
const AHEAD = 2;
async function recordVideo() {
  const w = parseInt(params.get('w'), 10), h = parseInt(params.get('h'), 10);
  const fps = parseFloat(params.get('fps'));
  const frames = parseInt(params.get('frames'), 10);
  renderer.setPixelRatio(1);
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  const ws = new WebSocket(`ws://${location.host}/frames`);
  ws.binaryType = 'arraybuffer';
  await new Promise((resolve, reject) => { ws.onopen = resolve; ws.onerror = () => reject(new Error('no /frames socket')); });
  let taken = 0;
  let wake = null;
  ws.onmessage = () => { taken += 1; if (wake) { wake(); wake = null; } };
  const gl = renderer.getContext();
  const pixels = new Uint8Array(w * h * 4);
  // Milliseconds spent drawing, reading back, sending, and waiting for drumsim.
  const spent = { draw_ms: 0, read_ms: 0, send_ms: 0, wait_ms: 0 };
  try {
    for (let i = 0; i < frames; i++) {
      let t0 = performance.now();
      while (i - taken >= AHEAD) await new Promise((resolve) => { wake = resolve; });
      let t1 = performance.now();
      spent.wait_ms += t1 - t0;
      const t = i / fps;
      setTime(t);
      if (follow) updateFollow(t);
      renderer.render(scene, camera);
      gl.finish();
      t0 = performance.now();
      spent.draw_ms += t0 - t1;
      gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
      t1 = performance.now();
      spent.read_ms += t1 - t0;
      ws.send(pixels);
      spent.send_ms += performance.now() - t1;
    }
    while (taken < frames) await new Promise((resolve) => { wake = resolve; });
    for (const k of Object.keys(spent)) spent[k] /= frames;
    ws.send(`done ${JSON.stringify(spent)}`);
  } catch (e) {
    ws.send(`error: ${e.message || e}`);
  }
}

function prepareMeshes(root) {
  root.traverse((o) => {
    if (!o.isMesh) return;
    o.frustumCulled = false;
    // Software rendering: Lambert shading instead of physically based, metals lightened as
    // the missing reflections would have.
    if (software) {
      const m = o.material;
      const color = m.color.clone();
      if (m.metalness > 0.5) color.lerp(new THREE.Color(1, 1, 1), 0.15);
      o.material = new THREE.MeshLambertMaterial({ color, side: m.side, name: m.name });
    }
  });
}

async function load() {
  const info = await fetch('/info.json').then((r) => r.json());
  if (info.live) return loadLive(info);
  const contacts = await fetch('/contacts.json').then((r) => r.json());
  $('title').textContent = `${info.song}  ·  ${info.sound} sound  ·  kit ${info.kit}`;
  document.title = `drumsim · ${info.song}`;
  const gltf = await new GLTFLoader().loadAsync('/song.glb');
  scene.add(gltf.scene);
  prepareMeshes(gltf.scene);
  if (gltf.animations.length) {
    mixer = new THREE.AnimationMixer(gltf.scene);
    const action = mixer.clipAction(gltf.animations[0]);
    action.setLoop(THREE.LoopOnce, 1);
    action.clampWhenFinished = true;
    action.play();
  }
  for (const c of contacts.contacts) {
    const p = litPiece(c.piece);
    if (!p) continue;
    p.times.push(c.time_s);
    p.limbs.push(c.limb);
    p.levels.push(Math.min(1, Math.max(0.35, c.speed_mps / 6)));
  }
  for (const p of pieces.values()) {
    const order = p.times.map((_, i) => i).sort((a, b) => p.times[a] - p.times[b]);
    p.times = order.map((i) => p.times[i]);
    p.limbs = order.map((i) => p.limbs[i]);
    p.levels = order.map((i) => p.levels[i]);
  }
  api.contacts = contacts.contacts;
  api.info = info;
  duration = info.duration_s;
  audio.src = '/song.wav';
  await new Promise((resolve, reject) => {
    audio.addEventListener('loadedmetadata', resolve, { once: true });
    audio.addEventListener('error', () => reject(new Error('cannot load /song.wav')), { once: true });
  });
  duration = audio.duration || duration;
  setView(params.get('view') || 'audience');
  api.setFollow(follow);
  api.setSticking(sticking);
  if (params.get('video') === '1') return recordVideo();
  if (params.has('t')) await api.seek(parseFloat(params.get('t')) || 0);
  setTime(audio.currentTime);
  requestAnimationFrame(frame);
  api.ready = true;
  if (params.get('autoplay') === '1') audio.play().catch((e) => api.errors.push(`autoplay: ${e}`));
}

$('play').addEventListener('click', () => (audio.paused ? audio.play() : audio.pause()));
audio.addEventListener('play', () => { $('play').textContent = 'Pause'; });
audio.addEventListener('pause', () => { $('play').textContent = 'Play'; });
$('scrub').addEventListener('input', (e) => { scrubbing = true; audio.currentTime = parseFloat(e.target.value) * duration; });
$('scrub').addEventListener('change', () => { scrubbing = false; });
$('speed').addEventListener('change', (e) => { audio.playbackRate = parseFloat(e.target.value); });
document.querySelectorAll('[data-view]').forEach((b) => b.addEventListener('click', () => { api.setFollow(false); setView(b.dataset.view); }));
$('follow').addEventListener('change', (e) => api.setFollow(e.target.checked));
$('sticking').addEventListener('change', (e) => api.setSticking(e.target.checked));
window.addEventListener('keydown', (e) => {
  if (e.target.tagName === 'INPUT' && e.target.type !== 'checkbox') return;
  if (e.key === ' ') { e.preventDefault(); $('play').click(); }
  else if (e.key === '1') setView('audience');
  else if (e.key === '2') setView('seat');
  else if (e.key === '3') setView('top');
  else if (e.key === 'f') api.setFollow(!follow);
  else if (e.key === 's') api.setSticking(!sticking);
});
window.addEventListener('resize', () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight);
  scaling.intervals.length = 0;
});

load().catch((e) => {
  api.errors.push(String(e));
  showMessage(`drumsim viewer: ${e.message || e}`);
});
