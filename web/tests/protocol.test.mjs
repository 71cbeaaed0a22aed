// The viewer's protocol module in plain node (no browser, no dependencies):
// node --test web/tests/protocol.test.mjs

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';

// web/ has no package.json, so node would read protocol.js as CommonJS; load it as a module.
const src = readFileSync(new URL('../protocol.js', import.meta.url), 'utf8');
const P = await import(`data:text/javascript;base64,${Buffer.from(src).toString('base64')}`);

// An ERROR message as the server encodes it (docs/protocol.md): header, code, length, text.
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
