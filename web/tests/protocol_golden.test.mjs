// The viewer's decoder and encoders against the golden byte files the Rust encoder writes
// (tests/data/protocol/, checked on the Rust side by crates/lumo-server/tests/integration/protocol_golden.rs).
// Plain node, no browser: node --test web/tests/protocol_golden.test.mjs

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync, readdirSync } from 'node:fs';

// web/ has no package.json, so node would read protocol.js as CommonJS; load it as a module.
const src = readFileSync(new URL('../protocol.js', import.meta.url), 'utf8');
const P = await import(`data:text/javascript;base64,${Buffer.from(src).toString('base64')}`);

const DIR = new URL('../../tests/data/protocol/', import.meta.url);
const bytes = (name) => {
  const b = readFileSync(new URL(`${name}.bin`, DIR));
  return b.buffer.slice(b.byteOffset, b.byteOffset + b.byteLength);
};
const expected = (name) => JSON.parse(readFileSync(new URL(`${name}.json`, DIR), 'utf8'));

// f32 fields decode to the nearest double of the stored float; the JSON holds the value the
// Rust test chose (all exactly representable), so they compare equal.
const SERVER = readdirSync(DIR)
  .filter((f) => f.endsWith('.bin') && !f.startsWith('client_'))
  .map((f) => f.slice(0, -4));

test('the golden files cover every server message kind', () => {
  const kinds = SERVER.map((n) => expected(n).kind).sort((a, b) => a - b);
  assert.deepEqual(kinds, Object.values(P.KIND).sort((a, b) => a - b));
});

for (const name of SERVER) {
  test(`decodes ${name}.bin as the Rust encoder meant it`, () => {
    const msg = P.decode(bytes(name));
    for (const [key, value] of Object.entries(expected(name))) {
      assert.deepEqual(msg[key], value, `${name}: field ${key}`);
    }
  });
}

test('encodes a CAMERA exactly as the server decodes it', () => {
  const camera = expected('client_camera');
  assert.deepEqual(new Uint8Array(P.encodeCamera(camera)), new Uint8Array(bytes('client_camera')));
});

test('encodes PARAMS exactly as the server decodes them', () => {
  const { integrator, mode } = expected('client_params');
  assert.deepEqual(
    new Uint8Array(P.encodeParams(integrator, mode)),
    new Uint8Array(bytes('client_params')),
  );
});
