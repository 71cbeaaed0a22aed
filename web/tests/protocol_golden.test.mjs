// The viewer's decoder and encoders against the golden byte files the Rust encoder writes
// (tests/data/protocol/, checked on the Rust side by crates/lumo-server/tests/integration/protocol_golden.rs).
// Plain node, no browser: node --test web/tests/protocol_golden.test.mjs

import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync, readdirSync } from 'node:fs';

// web/package.json marks web/*.js as ES modules, so node imports them as the browser does.
import * as P from '../protocol.js';

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

// Which bytes the decoder reads: DataView's getters, wrapped for the next test.
function offsetsRead(buf) {
  const seen = new Set();
  const saved = {};
  for (const name of Object.getOwnPropertyNames(DataView.prototype)) {
    if (!name.startsWith('get') || name === 'getBuffer') continue;
    saved[name] = DataView.prototype[name];
    DataView.prototype[name] = function (offset, ...rest) {
      seen.add(offset);
      return saved[name].call(this, offset, ...rest);
    };
  }
  try {
    P.decode(buf);
  } finally {
    Object.assign(DataView.prototype, saved);
  }
  return seen;
}

test('every field of the layout is read from the golden files, and their sizes agree', () => {
  const covered = new Set();
  for (const name of SERVER) {
    const buf = bytes(name);
    const kind = new Uint8Array(buf)[0];
    const [type, m] = Object.entries(P.MESSAGES).find(([, l]) => l.kind === kind);
    const seen = offsetsRead(buf);
    const dv = new DataView(buf);
    let tail = 0;
    for (const [field, f] of Object.entries(m.fields)) {
      if (f.type === 'reserved') continue;
      if (typeof f.count === 'number') {
        for (let i = 0; i < f.count; i++) {
          assert.ok(seen.has(f.offset + i * f.bytes), `${type}.${field}[${i}] never read`);
        }
      } else {
        // The variable tail: its size follows from the fields it names.
        const n = f.count.fields.reduce((p, c) => {
          const g = m.fields[c];
          return p * dv[g.bytes === 4 ? 'getUint32' : 'getUint16'](g.offset, true);
        }, f.count.factor);
        tail = n * f.bytes;
      }
      covered.add(`${type}.${field}`);
    }
    assert.equal(buf.byteLength, m.bytes + tail, `${name}.bin size`);
  }
  const all = Object.entries(P.MESSAGES).flatMap(([t, m]) => Object.entries(m.fields)
    .filter(([, f]) => f.type !== 'reserved').map(([n]) => `${t}.${n}`));
  assert.deepEqual(all.filter((f) => !covered.has(f)), []);
});

test('encodes a CAMERA exactly as the server decodes it', () => {
  const camera = expected('client_camera');
  assert.deepEqual(new Uint8Array(P.encodeCamera(camera)), new Uint8Array(bytes('client_camera')));
});

test('encodes ANIMATE exactly as the server decodes it', () => {
  const { playing } = expected('client_animate');
  assert.deepEqual(new Uint8Array(P.encodeAnimate(playing)), new Uint8Array(bytes('client_animate')));
});

test('encodes PARAMS exactly as the server decodes them', () => {
  const { integrator, mode } = expected('client_params');
  assert.deepEqual(
    new Uint8Array(P.encodeParams(integrator, mode)),
    new Uint8Array(bytes('client_params')),
  );
});

test('encodes PICK exactly as the server decodes it', () => {
  const { request, uv } = expected('client_pick');
  assert.deepEqual(new Uint8Array(P.encodePick(request, uv)), new Uint8Array(bytes('client_pick')));
});

test('encodes EDIT exactly as the server decodes it', () => {
  const { op, index, value } = expected('client_edit');
  assert.deepEqual(
    new Uint8Array(P.encodeEdit(op, index, value)),
    new Uint8Array(bytes('client_edit')),
  );
});
