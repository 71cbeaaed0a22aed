// Scene edits: shift+click picks what is under the cursor (the server casts the ray: PICK),
// shift+drag moves the picked object or light in the plane facing the camera, and the edit
// panel changes its base colour and its light's intensity (EDIT). Every edit sends the new
// absolute value; the server checks it, applies it at its next restart and echoes it to
// every viewer (docs/protocol.md, PICK and EDIT).

import { encodeEdit, encodePick } from './protocol.js';

// Moves go out at most this often while dragging, like cameras.
const EDIT_SEND_MS = 30;
// The server's bounds (docs/protocol.md, EDIT): an intensity above this is refused.
const MAX_RADIANCE = 1e6;

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => scale(a, 1 / Math.hypot(...a));

// The colour picker speaks sRGB; the scene's base colour is linear.
const toLinear = (c) => (c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4);
const toSrgb = (c) => (c <= 0.0031308 ? 12.92 * c : 1.055 * c ** (1 / 2.4) - 0.055);
const hex = (rgb) => `#${rgb.map((c) => Math.round(255 * toSrgb(Math.min(1, Math.max(0, c))))
  .toString(16).padStart(2, '0')).join('')}`;
const fromHex = (h) => [1, 3, 5].map((i) => toLinear(parseInt(h.slice(i, i + 2), 16) / 255));

export class Editor {
  // canvas: the image; send(bytes) sends a message; camera() the camera shown now.
  constructor(canvas, send, camera) {
    this.canvas = canvas;
    this.send = send;
    this.camera = camera;
    this.selection = null;
    this.requests = 0;
    this.pendingMove = null;
    this.moveTimer = null;
    this.panel = document.getElementById('edit');
    this.nameEl = document.getElementById('edit-name');
    this.colorEl = document.getElementById('edit-color');
    this.intensityEl = document.getElementById('edit-intensity');
    this.colorEl.addEventListener('input', () => this.setColor(fromHex(this.colorEl.value)));
    this.intensityEl.addEventListener('input', () => this.setIntensity(2 ** Number(this.intensityEl.value)));
    canvas.addEventListener('pointerdown', (e) => this.down(e));
    canvas.addEventListener('pointermove', (e) => this.move(e));
    canvas.addEventListener('pointerup', (e) => this.up(e));
  }

  // Image position of a pointer event in [0,1]² (the canvas may be drawn scaled).
  uv(e) {
    const r = this.canvas.getBoundingClientRect();
    const clamp = (v) => Math.min(1, Math.max(0, v));
    return [clamp((e.clientX - r.left) / r.width), clamp((e.clientY - r.top) / r.height)];
  }

  down(e) {
    if (!e.shiftKey) return;
    this.drag = { start: [e.clientX, e.clientY], moved: false };
    this.canvas.setPointerCapture(e.pointerId);
  }

  move(e) {
    const d = this.drag;
    if (!d || !this.selection || this.selection.target === 'nothing') return;
    const dx = e.clientX - d.start[0];
    const dy = e.clientY - d.start[1];
    if (!d.moved && Math.hypot(dx, dy) < 3) return;
    if (!d.moved) {
      d.moved = true;
      d.from = this.selection.position;
    }
    // World units per screen pixel at the picked point's distance: the field of view spans
    // the canvas's shorter side, so the object follows the cursor.
    const c = this.camera();
    const r = this.canvas.getBoundingClientRect();
    const dist = Math.hypot(...sub(this.selection.point, c.origin));
    const perPixel = (2 * dist * Math.tan((c.fov * Math.PI) / 360)) / Math.min(r.width, r.height);
    const fwd = norm(sub(c.target, c.origin));
    const right = norm(cross(fwd, c.up));
    const up = cross(right, fwd);
    const step = add(scale(right, dx * perPixel), scale(up, -dy * perPixel));
    this.pendingMove = add(d.from, step);
    if (!this.moveTimer) this.moveTimer = setTimeout(() => this.sendMove(), EDIT_SEND_MS);
  }

  up(e) {
    const d = this.drag;
    this.drag = null;
    if (!d) return;
    if (!d.moved) {
      this.requests += 1;
      this.send(encodePick(this.requests, this.uv(e)));
    }
  }

  sendMove() {
    this.moveTimer = null;
    const s = this.selection;
    if (!this.pendingMove || !s) return;
    const op = s.target === 'light' ? 'moveLight' : 'moveInstance';
    this.send(encodeEdit(op, s.index, this.pendingMove));
    s.position = this.pendingMove;
    this.pendingMove = null;
  }

  setColor(rgb) {
    const s = this.selection;
    if (!s || !s.hasColor) return;
    s.color = rgb;
    this.send(encodeEdit('baseColor', s.material, rgb));
  }

  // Scales the intensity the pick reported (an area light's emission or a light's intensity).
  setIntensity(factor) {
    const s = this.selection;
    if (!s || !s.baseEmission) return;
    const value = s.baseEmission.map((c) => Math.min(MAX_RADIANCE, c * factor));
    if (s.target === 'light') this.send(encodeEdit('lightIntensity', s.index, value));
    else this.send(encodeEdit('emission', s.material, value));
  }

  // The server's answer to the newest pick: select it and fill the panel.
  onPick(msg) {
    if (msg.request !== this.requests) return;
    if (msg.target === 'nothing') {
      this.selection = null;
      this.panel.hidden = true;
      return;
    }
    const lit = Math.max(...msg.emission) > 0;
    this.selection = { ...msg, baseEmission: lit ? msg.emission : null };
    this.panel.hidden = false;
    this.nameEl.textContent = `${msg.target} ${msg.index}: ${msg.name}`;
    this.colorEl.disabled = !msg.hasColor;
    if (msg.hasColor) this.colorEl.value = hex(msg.color);
    this.intensityEl.disabled = !lit;
    this.intensityEl.value = 0;
  }

  // An edit applied (by this viewer or another): keep the selection's values current.
  onEdit(msg) {
    const s = this.selection;
    if (!s) return;
    const onSelection = {
      moveInstance: s.target === 'object' && msg.index === s.index,
      moveLight: s.target === 'light' && msg.index === s.index,
      lightIntensity: s.target === 'light' && msg.index === s.index,
      emission: s.target === 'object' && msg.index === s.material,
      baseColor: s.target === 'object' && msg.index === s.material,
    }[msg.op];
    if (!onSelection || this.drag) return;
    if (msg.op === 'moveInstance' || msg.op === 'moveLight') s.position = msg.value;
    if (msg.op === 'baseColor') {
      s.color = msg.value;
      this.colorEl.value = hex(msg.value);
    }
  }
}
