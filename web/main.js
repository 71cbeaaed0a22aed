// The viewer: the paper's client loop at display rate — process input, rasterise new samples,
// repaint, (swap), fetch new samples — whatever the server's speed.

import {
  camerasInFlightAfterError, decode, encodeAnimate, encodeCamera, encodeParams, KIND, STREAM,
} from './protocol.js';
import { floatFormats, loadText, program } from './gl.js';
import { SampleStream } from './stream.js';
import { Display } from './display.js';
import { Navigation } from './navigation.js';
import { Editor } from './edit.js';
import { controls, overlay } from './ui.js';

// Samples rasterised per displayed frame adapt to what splatting costs (the paper's client
// adjusts its batch size to the server's speed). Every PROBE_EVERY frames, two frames splat
// nothing: the first lets GPU work still queued from earlier frames drain (WebGL is pipelined),
// the second measures the repaint alone. Splatting may then take what is left of the target frame time,
// or as long as the repaint itself where the repaint alone already misses the target (a slow
// GPU or a software rasteriser): the display rate never drops below half of what the GPU can
// repaint, and samples are not thrown away because the *repaint* is slow. Samples that pile up
// beyond a few frames' worth are dropped, oldest first — each is an independent estimate, so
// dropping some only costs noise, never bias.
const BUDGET_MIN = 1000;
const BUDGET_MAX = 500000;
const TARGET_FRAME_S = 1 / 45;
const BACKLOG_FRAMES = 4;
const PROBE_EVERY = 16;
// Splatting never gets more than this per frame, however slow the repaint; a frame slower than
// SLOW_FRAME_S halves the budget at once.
const MAX_SPLAT_S = 0.1;
const SLOW_FRAME_S = 0.25;
// Camera updates go out at most this often while dragging.
const CAMERA_SEND_MS = 30;

const canvas = document.getElementById('view');
const overlayEl = document.getElementById('overlay');
const statusEl = document.getElementById('status');

const state = {
  hello: null, epoch: 0, integrator: 'path', mode: 'progressive', inflight: 0, serverCamera: null,
  rate: 0, dropped: 0, clientDropped: 0, viewers: 1, serverSamples: 0, fps: 0, frames: 0, errors: [],
  lastLocalMove: -1e9,
  // The epoch whose first filtered frame was last drawn, and when (the animation frame's time):
  // what web/tests/latency.mjs measures a camera move against.
  shownEpoch: -1, shownAt: 0,
};
const queue = [];
let queuedSamples = 0;
let budget = 20000;
let gpu = null;
// Frame-time estimates (s): repaint only (probe frames) and a normal frame.
// phase of the frame just drawn: 'normal', 'drain' (first no-splat frame), 'probe' (second).
const timing = { repaint: null, full: TARGET_FRAME_S, phase: 'normal', index: 0 };

async function initGpu(hello) {
  canvas.width = hello.width;
  canvas.height = hello.height;
  const gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true });
  if (!gl) throw new Error('WebGL2 is not available');
  const formats = floatFormats(gl);
  const src = {};
  for (const f of ['quad.vert', 'splat.vert', 'splat.frag', 'variance.frag', 'mip.frag', 'display.frag']) {
    src[f] = await loadText(`shaders/${f}`);
  }
  const programs = {
    splat: program(gl, src['splat.vert'], src['splat.frag']),
    variance: program(gl, src['splat.vert'], src['variance.frag']),
    mip: program(gl, src['quad.vert'], src['mip.frag']),
  };
  const w = hello.width;
  const h = hello.height;
  return {
    gl,
    formats,
    quad: gl.createVertexArray(),
    camera: new SampleStream(gl, programs, formats, w, h),
    light: new SampleStream(gl, programs, formats, w, h),
    display: new Display(gl, program(gl, src['quad.vert'], src['display.frag']), w, h),
  };
}

function resetImage() {
  queue.length = 0;
  queuedSamples = 0;
  if (!gpu) return;
  gpu.camera.reset();
  gpu.light.reset();
  gpu.display.hasFrame = false;
}

const ws = new WebSocket(`ws://${location.host}/ws`);
ws.binaryType = 'arraybuffer';

let pendingCamera = null;
let sendTimer = null;
let lastCameraSend = -1e9;
function sendCamera() {
  sendTimer = null;
  if (!pendingCamera || ws.readyState !== WebSocket.OPEN) return;
  ws.send(encodeCamera(pendingCamera));
  lastCameraSend = performance.now();
  state.inflight += 1;
  pendingCamera = null;
}

const nav = new Navigation(canvas, (camera) => {
  // Restart at once locally; samples of the old view are ignored until the server confirms.
  resetImage();
  state.lastLocalMove = performance.now();
  pendingCamera = structuredClone(camera);
  // The first move after a pause goes out at once (the server starts the new view's first
  // frame 30 ms sooner); moves that follow within CAMERA_SEND_MS are merged into one.
  if (sendTimer) return;
  const wait = CAMERA_SEND_MS - (performance.now() - lastCameraSend);
  if (wait <= 0) sendCamera();
  else sendTimer = setTimeout(sendCamera, wait);
});

const editor = new Editor(
  canvas,
  (bytes) => { if (ws.readyState === WebSocket.OPEN) ws.send(bytes); },
  () => nav.camera,
);

const ui = controls(
  () => {},
  (integrator, mode) => {
    if (ws.readyState === WebSocket.OPEN) ws.send(encodeParams(integrator, mode));
  },
  (m) => { nav.mode = m; },
  (playing) => {
    if (ws.readyState === WebSocket.OPEN) ws.send(encodeAnimate(playing));
  },
);

ws.onmessage = async (ev) => {
  let msg;
  try {
    msg = decode(ev.data);
  } catch (e) {
    state.errors.push(String(e));
    return;
  }
  switch (msg.kind) {
    case KIND.HELLO:
      state.hello = msg;
      state.epoch = msg.epoch;
      state.integrator = msg.integrator;
      state.mode = msg.mode;
      ui.setParams(msg.integrator, msg.mode);
      nav.set(msg.camera);
      state.serverCamera = msg.camera;
      try {
        gpu = await initGpu(msg);
        requestAnimationFrame(frame);
      } catch (e) {
        statusEl.textContent = String(e);
        state.errors.push(String(e));
      }
      break;
    case KIND.CAMERA:
      state.inflight = Math.max(0, state.inflight - 1);
      state.serverCamera = msg.camera;
      if (msg.epoch !== state.epoch) {
        state.epoch = msg.epoch;
        resetImage();
      }
      // Follow the server (another viewer may have moved) unless this viewer is moving.
      if (state.inflight === 0 && !pendingCamera && performance.now() - state.lastLocalMove > 300) {
        nav.set(msg.camera);
      }
      break;
    case KIND.PARAMS:
      state.integrator = msg.integrator;
      state.mode = msg.mode;
      ui.setParams(msg.integrator, msg.mode);
      break;
    case KIND.ANIMATE:
      // Each animation frame arrives as a new epoch (CAMERA); this only tracks play/pause.
      state.animation = msg;
      ui.setAnimation(msg.playing);
      break;
    case KIND.PICK:
      editor.onPick(msg);
      break;
    case KIND.EDIT:
      // The restart that applies it arrives as a CAMERA with a new epoch, as any restart.
      editor.onEdit(msg);
      break;
    case KIND.SAMPLES:
    case KIND.FRAME:
      if (msg.epoch === state.epoch && state.inflight === 0 && !pendingCamera) {
        queue.push(msg);
        queuedSamples += msg.count || 0;
      }
      break;
    case KIND.STATS:
      state.rate = msg.rate;
      state.dropped = msg.dropped;
      state.viewers = msg.viewers;
      state.serverSamples = msg.samples;
      break;
    case KIND.ERROR: {
      state.errors.push(`${msg.code}: ${msg.message}`);
      statusEl.textContent = `server: ${msg.message}`;
      const before = state.inflight;
      state.inflight = camerasInFlightAfterError(state.inflight, msg.code);
      if (state.inflight < before && state.inflight === 0 && !pendingCamera && state.serverCamera) {
        // The server refused our camera and kept rendering its own: show that view again
        // (its samples are accepted now that nothing is in flight).
        nav.set(state.serverCamera);
        resetImage();
      }
      break;
    }
    default:
      break;
  }
};
ws.onclose = () => { statusEl.textContent = 'disconnected from the server'; };

let last = performance.now();
let lastOverlay = 0;
let lastLook = '';
function frame(now) {
  const dt = Math.min(0.1, (now - last) / 1000);
  last = now;
  if (dt > 0) state.fps = state.fps * 0.9 + (1 / dt) * 0.1;
  nav.update(dt);
  const { camera, light, display, quad } = gpu;
  // dt is the interval that ended with this callback: it measures the previous frame's work.
  if (dt > 0) {
    if (timing.phase === 'probe') {
      timing.repaint = timing.repaint === null ? dt : timing.repaint * 0.7 + dt * 0.3;
    } else if (timing.phase === 'normal' && timing.repaint !== null) {
      timing.full = timing.full * 0.8 + dt * 0.2;
      const allowance = Math.min(MAX_SPLAT_S, Math.max(TARGET_FRAME_S - timing.repaint, timing.repaint));
      const splat = Math.max(0, timing.full - timing.repaint);
      if (dt > SLOW_FRAME_S) budget *= 0.5;
      else if (splat > allowance * 1.2) budget *= 0.8;
      else if (splat < allowance * 0.8 && queuedSamples > budget) budget *= 1.15;
      budget = Math.min(BUDGET_MAX, Math.max(BUDGET_MIN, budget));
    }
  }
  timing.index += 1;
  // The first probe comes at once: until the repaint cost is known the budget stays put.
  const k = timing.index % PROBE_EVERY;
  timing.phase = timing.index === 2 || k === 0 ? 'drain'
    : timing.index === 3 || k === 1 ? 'probe' : 'normal';
  while (queuedSamples > BACKLOG_FRAMES * budget && queue.length > 1) {
    const m = queue.shift();
    if (m.kind === KIND.SAMPLES) {
      queuedSamples -= m.count;
      state.clientDropped += m.count;
    }
    // A dropped light message takes its splats and its share of light paths together.
  }
  let left = timing.phase === 'normal' ? budget : 0;
  let fresh = false;
  while (queue.length > 0 && left > 0) {
    const m = queue.shift();
    fresh = true;
    if (m.kind === KIND.FRAME) {
      display.uploadFrame(m);
    } else {
      (m.stream === STREAM.camera ? camera : light).splat(m);
      left -= m.count;
      queuedSamples -= m.count;
    }
  }
  const frameMode = state.mode !== 'progressive';
  // In a frame mode the picture changes only with a new frame, a restart or a display
  // parameter: the same picture is not drawn again (with a software GL, SwiftShader, each
  // repaint took CPU from the server's next frame).
  const look = `${state.epoch}|${display.hasFrame}|${JSON.stringify(ui.params)}`;
  if (!frameMode || fresh || look !== lastLook) {
    lastLook = look;
    camera.buildMips(quad);
    light.buildMips(quad);
    display.draw(quad, camera, light, ui.params, frameMode);
    if (frameMode && display.hasFrame && state.shownEpoch !== state.epoch) {
      state.shownEpoch = state.epoch;
      state.shownAt = now;
    }
  }
  state.frames += 1;
  if (now - lastOverlay > 100) {
    lastOverlay = now;
    const h = state.hello;
    const pixels = h.width * h.height;
    overlay(overlayEl, {
      name: h.name, width: h.width, height: h.height,
      integrator: state.integrator, mode: state.mode,
      rate: state.rate,
      spp: frameMode ? display.frames : camera.samples / pixels,
      fps: state.fps,
      lod: frameMode ? 0 : Math.max(0, camera.samples > 0 ? camera.baseLod() : light.baseLod()),
      samples: camera.samples, lightPaths: light.lightPaths,
      dropped: state.dropped, viewers: state.viewers,
    });
  }
  requestAnimationFrame(frame);
}

// A small hook for tests and scripts: counters and a read-back of the displayed image.
window.lumo = {
  state,
  counts() {
    return {
      ready: !!gpu,
      epoch: state.epoch,
      frames: state.frames,
      cameraSamples: gpu ? gpu.camera.samples : 0,
      lightSamples: gpu ? gpu.light.samples : 0,
      lightPaths: gpu ? gpu.light.lightPaths : 0,
      frameCount: gpu ? gpu.display.frames : 0,
      clientDropped: state.clientDropped,
      budget,
      precision: gpu ? gpu.formats.precision : null,
      params: { ...ui.params },
      errors: state.errors.slice(),
      overlay: overlayEl.textContent,
      selection: editor.selection,
    };
  },
  pixels() {
    const gl = gpu.gl;
    const w = canvas.width;
    const h = canvas.height;
    const px = new Uint8Array(w * h * 4);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    return { width: w, height: h, data: Array.from(px) };
  },
};
