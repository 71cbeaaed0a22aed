// Camera navigation: orbit (drag turns around the target, wheel dollies) and fly (drag looks
// around, W/A/S/D/Q/E move). Every change calls onChange with the new camera.

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => scale(a, 1 / Math.hypot(...a));

// Rotates v around unit axis k by angle a (Rodrigues).
function rotate(v, k, a) {
  const c = Math.cos(a);
  const s = Math.sin(a);
  return add(add(scale(v, c), scale(cross(k, v), s)), scale(k, dot(k, v) * (1 - c)));
}

export class Navigation {
  constructor(element, onChange) {
    this.camera = null;
    this.mode = 'orbit';
    this.onChange = onChange;
    this.keys = new Set();
    this.dragging = false;
    element.addEventListener('pointerdown', (e) => {
      // Shift+click and shift+drag belong to the scene editor (edit.js).
      if (e.shiftKey) return;
      this.dragging = true;
      this.last = [e.clientX, e.clientY];
      element.setPointerCapture(e.pointerId);
    });
    element.addEventListener('pointerup', () => { this.dragging = false; });
    element.addEventListener('pointermove', (e) => {
      if (!this.dragging || !this.camera) return;
      const dx = e.clientX - this.last[0];
      const dy = e.clientY - this.last[1];
      this.last = [e.clientX, e.clientY];
      this.turn(-dx * 0.005, -dy * 0.005);
    });
    element.addEventListener('wheel', (e) => {
      e.preventDefault();
      this.dolly(Math.exp(e.deltaY * 0.001));
    }, { passive: false });
    window.addEventListener('keydown', (e) => {
      if (e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement) return;
      this.keys.add(e.key.toLowerCase());
    });
    window.addEventListener('keyup', (e) => this.keys.delete(e.key.toLowerCase()));
  }

  set(camera) {
    this.camera = structuredClone(camera);
  }

  // Yaw around the up hint and pitch around the right axis.
  turn(yaw, pitch) {
    const c = this.camera;
    const up = norm(c.up);
    const fwd = sub(c.target, c.origin);
    const right = norm(cross(fwd, up));
    let dir = rotate(rotate(fwd, up, yaw), right, pitch);
    // Keep away from the poles, where the up hint stops defining a frame.
    if (Math.abs(dot(norm(dir), up)) > 0.98) dir = rotate(fwd, up, yaw);
    if (this.mode === 'orbit') {
      c.origin = sub(c.target, dir);
    } else {
      c.target = add(c.origin, dir);
    }
    this.onChange(c);
  }

  dolly(factor) {
    if (!this.camera) return;
    const c = this.camera;
    const back = sub(c.origin, c.target);
    if (this.mode === 'orbit') {
      c.origin = add(c.target, scale(back, factor));
    } else {
      const step = scale(back, factor - 1);
      c.origin = add(c.origin, step);
      c.target = add(c.target, step);
    }
    this.onChange(c);
  }

  // Called every frame: applies held movement keys (frame-rate independent).
  update(dt) {
    if (!this.camera || this.keys.size === 0) return;
    const c = this.camera;
    const fwd = sub(c.target, c.origin);
    const dist = Math.hypot(...fwd);
    const f = norm(fwd);
    const r = norm(cross(f, c.up));
    const u = norm(c.up);
    const speed = dist * dt;
    let move = [0, 0, 0];
    const k = this.keys;
    if (k.has('w')) move = add(move, f);
    if (k.has('s')) move = sub(move, f);
    if (k.has('d')) move = add(move, r);
    if (k.has('a')) move = sub(move, r);
    if (k.has('e')) move = add(move, u);
    if (k.has('q')) move = sub(move, u);
    if (dot(move, move) === 0) return;
    const step = scale(move, speed);
    c.origin = add(c.origin, step);
    if (this.mode === 'fly') c.target = add(c.target, step);
    this.onChange(c);
  }
}
