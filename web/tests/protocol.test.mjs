// The viewer's protocol module in plain node (no browser, no dependencies):
// node --test web/tests/protocol.test.mjs

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readdirSync, readFileSync } from 'node:fs';

// web/package.json marks web/*.js as ES modules, so node imports them as the browser does.
import * as P from '../protocol.js';

// An ERROR message as the server encodes it (docs/protocol.md): header, code, length, text.
// The offsets are written out here on purpose: they are the documented format, which the
// generated layout must agree with.
function errorMessage(code, text) {
  const bytes = new TextEncoder().encode(text);
  const buf = new ArrayBuffer(8 + bytes.length);
  const dv = new DataView(buf);
  dv.setUint8(0, P.KIND.ERROR);
  dv.setUint8(1, P.VERSION);
  dv.setUint16(4, code, true);
  dv.setUint16(6, bytes.length, true);
  new Uint8Array(buf, 8).set(bytes);
  return buf;
}

const WEB = new URL('../', import.meta.url);
const webModules = readdirSync(WEB).filter((f) => f.endsWith('.js') && f !== 'protocol_layout.js');

test('no viewer module holds a literal byte offset: they all come from protocol_layout.js', () => {
  // A DataView access, a typed-array view or a vertex attribute at a numeric offset.
  const literal = [
    /\b(get|set)(U?Int|Float|BigU?Int)\d+\(\s*\d/,
    /new (Uint8|Uint16|Float32)Array\(\s*[\w.]+\s*,\s*\d/,
    /vertexAttribPointer\([^)]*,\s*\d+\s*\)/,
  ];
  for (const f of webModules) {
    const src = readFileSync(new URL(f, WEB), 'utf8');
    src.split('\n').forEach((line, i) => {
      for (const re of literal) assert.ok(!re.test(line), `${f}:${i + 1}: ${line.trim()}`);
    });
  }
  assert.ok(webModules.includes('protocol.js') && webModules.includes('stream.js'));
});

test('the enumerations come from the layout, in wire-code order', () => {
  assert.deepEqual(P.MODES, P.ENUMS.mode.values.map((v) => v.name));
  // Integrator codes may have gaps (a code kept for an integrator of another branch):
  // names are looked up by code.
  P.ENUMS.integrator.values.forEach((v) => assert.equal(P.INTEGRATORS[v.code], v.name));
  assert.equal(Object.keys(P.INTEGRATORS).length, P.ENUMS.integrator.values.length);
  P.ENUMS.mode.values.forEach((v, i) => assert.equal(v.code, i));
  assert.deepEqual(P.STREAM, { camera: 0, light: 1 });
  assert.deepEqual([...P.CAMERA_REFUSAL_CODES], [1, 4, 5]);
  assert.throws(() => P.encodeParams('path', 'no-such-mode'), /unknown mode/);
});

test('the documented sizes match the layout', () => {
  assert.equal(P.SAMPLE_BYTES, 12);
  assert.equal(P.BATCH_HEADER, 20);
  assert.equal(P.FRAME_HEADER, 20);
  assert.deepEqual(
    Object.fromEntries(Object.entries(P.MESSAGES).map(([n, m]) => [n, m.bytes])),
    {
      HELLO: 68, CAMERA: 48, PARAMS: 8, ANIMATE: 16, PICK: 82, EDIT: 24, SAMPLES: 20, FRAME: 20,
      STATS: 36, FINISH: 32, ERROR: 8,
    },
  );
});

test('edits encode every op by name and refuse unknown ones; picks decode their target', () => {
  for (const op of P.EDIT_OPS) {
    const m = P.decode(P.encodeEdit(op, 3, [0.5, 0.25, 1]));
    assert.deepEqual(m, { kind: P.KIND.EDIT, op, index: 3, value: [0.5, 0.25, 1] });
  }
  assert.throws(() => P.encodeEdit('scaleInstance', 0, [1, 1, 1]), /unknown editOp/);
  const pick = P.decode(P.encodePick(7, [0.5, 0.5]));
  assert.equal(pick.target, 'nothing');
  assert.equal(pick.request, 7);
  assert.equal(pick.name, '');
});

test('truncated messages throw, never decode to garbage', () => {
  const full = errorMessage(4, 'x');
  for (let n = 0; n < 8; n++) assert.throws(() => P.decode(full.slice(0, n)));
  assert.throws(() => P.decode(new Uint8Array([0x55, 1, 0, 0]).buffer), /unknown message type/);
  assert.throws(() => P.decode(new Uint8Array([0x12, 2, 0, 0]).buffer), /protocol version/);
});

test('a refused CAMERA is no longer in flight, so samples are drawn again', () => {
  const msg = P.decode(errorMessage(4, 'camera origin coordinate 1e30 is beyond ±1e18'));
  assert.equal(msg.kind, P.KIND.ERROR);
  // One camera sent, refused: nothing in flight (main.js draws samples only at zero).
  assert.equal(P.camerasInFlightAfterError(1, msg.code), 0);
  // Two sent, the first refused: the second is still awaited.
  assert.equal(P.camerasInFlightAfterError(2, msg.code), 1);
  assert.equal(P.camerasInFlightAfterError(1, 1), 0, 'malformed');
  assert.equal(P.camerasInFlightAfterError(1, 5), 0, 'too large');
});

test('errors that cannot answer a CAMERA leave the count alone', () => {
  assert.equal(P.camerasInFlightAfterError(0, 4), 0, 'nothing in flight');
  assert.equal(P.camerasInFlightAfterError(1, 2), 1, 'unknown type');
  assert.equal(P.camerasInFlightAfterError(1, 3), 1, 'wrong version');
  assert.equal(P.camerasInFlightAfterError(1, 6), 1, 'text message');
});
