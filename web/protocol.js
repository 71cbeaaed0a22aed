// The binary protocol of docs/protocol.md. Every message: [type u8][version u8][reserved u16],
// then a little-endian payload. Every offset, type and code comes from protocol_layout.js,
// which a Rust test generates from the message tables in crates/lumo-server/src/protocol/;
// this file holds no byte offsets of its own (web/tests/protocol.test.mjs checks that).

import { ENUMS, HEADER_BYTES, MESSAGES, RECORDS, VERSION } from './protocol_layout.js';

export { ENUMS, MESSAGES, RECORDS, VERSION };

const HEADER = RECORDS.HEADER.fields;
// The packed sample: the viewer hands the bytes to the GPU as vertex attributes.
export const SAMPLE = RECORDS.SAMPLE;
export const SAMPLE_BYTES = SAMPLE.bytes;
// Bytes before the samples of a SAMPLES message and before the pixels of a FRAME.
export const BATCH_HEADER = MESSAGES.SAMPLES.fields.samples.offset;
export const FRAME_HEADER = MESSAGES.FRAME.fields.pixels.offset;

export const KIND = Object.fromEntries(Object.entries(MESSAGES).map(([n, m]) => [n, m.kind]));
const NAME_OF_KIND = Object.fromEntries(Object.entries(MESSAGES).map(([n, m]) => [m.kind, n]));

// An enumeration's codes by name, and its names by code.
const codes = (e) => Object.fromEntries(ENUMS[e].values.map((v) => [v.name, v.code]));
const names = (e) => {
  const out = [];
  for (const v of ENUMS[e].values) out[v.code] = v.name;
  return out;
};
export const INTEGRATORS = names('integrator');
export const MODES = names('mode');
export const STREAM = codes('stream');
export const ERROR_CODE = codes('errorCode');
export const PICK_TARGETS = names('pickTarget');
export const EDIT_OPS = names('editOp');

function codeOf(e, name) {
  const code = codes(e)[name];
  if (code === undefined) throw new Error(`unknown ${e} ${name}`);
  return code;
}

// ERROR codes with which the server refuses a CAMERA: malformed, invalid value, too large.
// The server answers every CAMERA a viewer sends, in order, with a CAMERA (taken) or an ERROR
// (refused); the viewer's PARAMS come from its own menus and are always valid.
export const CAMERA_REFUSAL_CODES = new Set([
  ERROR_CODE.malformed, ERROR_CODE.invalidValue, ERROR_CODE.tooLarge,
]);

// The viewer's count of CAMERA messages in flight after an ERROR with `code`: one fewer when
// the error refuses a camera and one is in flight. Without this, a refused camera stayed in
// flight for ever and the viewer ignored every sample until the next CAMERA arrived.
export function camerasInFlightAfterError(inflight, code) {
  return inflight > 0 && CAMERA_REFUSAL_CODES.has(code) ? inflight - 1 : inflight;
}

// DataView accessors per layout type (an enumeration's by its width).
const ACCESS = {
  u8: 'Uint8', bool: 'Uint8', u16: 'Uint16', unorm16: 'Uint16', u32: 'Uint32',
  u64: 'BigUint64', f32: 'Float32',
};
const access = (f) => (f.type === 'enum' ? ACCESS[`u${8 * f.bytes}`] : ACCESS[f.type]);

function get(dv, f, i = 0) {
  const v = dv[`get${access(f)}`](f.offset + i * f.bytes, true);
  if (f.type === 'u64') return Number(v);
  return f.type === 'bool' ? v !== 0 : v;
}

function set(dv, f, v, i = 0) {
  const x = f.type === 'u64' ? BigInt(v) : f.type === 'bool' ? Number(Boolean(v)) : v;
  dv[`set${access(f)}`](f.offset + i * f.bytes, x, true);
}

// Every fixed field of message `m` except reserved bytes: numbers (enumeration codes stay
// numbers), arrays for fields of several elements.
function fields(dv, m) {
  const out = {};
  for (const [name, f] of Object.entries(m.fields)) {
    if (f.type === 'reserved' || typeof f.count !== 'number') continue;
    out[name] = f.count === 1 ? get(dv, f)
      : Array.from({ length: f.count }, (_, i) => get(dv, f, i));
  }
  return out;
}

// Elements of the variable tail `name`, from the fields its count names.
function tailCount(m, name, values) {
  const { factor, fields: by } = m.fields[name].count;
  return by.reduce((n, f) => n * values[f], factor);
}

function text(buf, m, name, values) {
  const f = m.fields[name];
  return new TextDecoder().decode(new Uint8Array(buf, f.offset, tailCount(m, name, values) * f.bytes));
}

const camera = (f) => ({ origin: f.origin, target: f.target, up: f.up, fov: f.fov });

// Decodes a server message (an ArrayBuffer). Sample and frame payloads stay in the buffer:
// the viewer uploads them to the GPU as they are.
export function decode(buf) {
  const dv = new DataView(buf);
  if (buf.byteLength < HEADER_BYTES) throw new Error('short message');
  const kind = get(dv, HEADER.kind);
  const version = get(dv, HEADER.version);
  if (version !== VERSION) throw new Error(`protocol version ${version}`);
  const name = NAME_OF_KIND[kind];
  if (name === undefined) throw new Error(`unknown message type ${kind}`);
  const m = MESSAGES[name];
  if (buf.byteLength < m.bytes) throw new Error(`short ${name} message`);
  const f = fields(dv, m);
  switch (kind) {
    case KIND.HELLO: {
      if (f.sampleBytes !== SAMPLE_BYTES) throw new Error('unexpected sample size');
      return {
        kind, width: f.width, height: f.height, triangles: f.triangles, threads: f.threads,
        integrator: INTEGRATORS[f.integrator], mode: MODES[f.mode],
        epoch: f.epoch, camera: camera(f), name: text(buf, m, 'name', f),
      };
    }
    case KIND.CAMERA: return { kind, epoch: f.epoch, camera: camera(f) };
    case KIND.PARAMS:
      return { kind, integrator: INTEGRATORS[f.integrator], mode: MODES[f.mode] };
    case KIND.SAMPLES: return { kind, ...f, buffer: buf };
    case KIND.FRAME: return { kind, ...f, mode: MODES[f.mode], buffer: buf };
    case KIND.ERROR: return { kind, code: f.code, message: text(buf, m, 'message', f) };
    case KIND.PICK: {
      const { nameLength, ...rest } = f;
      return { kind, ...rest, target: PICK_TARGETS[f.target], name: text(buf, m, 'name', f) };
    }
    case KIND.EDIT: return { kind, op: EDIT_OPS[f.op], index: f.index, value: f.value };
    // Messages of plain numeric fields (STATS, FINISH, and any new one) need no code here:
    // their fields come out under the names the layout gives them.
    default: return { kind, ...f };
  }
}

// A message of layout `m` with the given field values (reserved bytes and the epoch of
// viewer messages stay 0).
function encode(m, values) {
  const dv = new DataView(new ArrayBuffer(m.bytes));
  set(dv, HEADER.kind, m.kind);
  set(dv, HEADER.version, VERSION);
  for (const [name, v] of Object.entries(values)) {
    const f = m.fields[name];
    if (Array.isArray(v)) v.forEach((x, i) => set(dv, f, x, i));
    else set(dv, f, v);
  }
  return dv.buffer;
}

export function encodeCamera(c) {
  return encode(MESSAGES.CAMERA, { origin: c.origin, target: c.target, up: c.up, fov: c.fov });
}

export function encodeParams(integrator, mode) {
  return encode(MESSAGES.PARAMS, {
    integrator: codeOf('integrator', integrator), mode: codeOf('mode', mode),
  });
}

// Play (true) or pause (false) the animation of `lumo serve --animate`.
export function encodeAnimate(playing) {
  return encode(MESSAGES.ANIMATE, { playing });
}

// Ask what is under image position uv ([0,1]², x right, y down); the server answers with a
// PICK carrying the same request number.
export function encodePick(request, uv) {
  return encode(MESSAGES.PICK, { request, uv });
}

// Change the scene: op is an editOp name, value the new absolute value (three numbers).
// The server checks the bounds (docs/protocol.md, EDIT) and answers a refusal with ERROR.
export function encodeEdit(op, index, value) {
  return encode(MESSAGES.EDIT, { op: codeOf('editOp', op), index, value });
}
