// The wire layout of docs/protocol.md as data, GENERATED from the Rust message tables
// (crates/lumo-server/src/protocol/): do not edit. After changing a table, rewrite it with
// LUMO_BLESS=1 cargo test --release -p lumo-server --test integration protocol_layout
//
// MESSAGES: per message, its type byte, fixed size in bytes (header included) and fields:
// byte offset from the start of the message, element type and bytes, and count (a number,
// or factor × the product of earlier fields for the variable tail). RECORDS: the common
// header and the packed sample. ENUMS: wire codes, names and display labels.

export const VERSION = 1;
export const HEADER_BYTES = 4;

export const ENUMS = {
  integrator: {
    bytes: 1,
    values: [
      { code: 0, name: 'path', label: 'path' },
      { code: 1, name: 'light', label: 'light' },
      { code: 2, name: 'both', label: 'both' },
      { code: 3, name: 'bdpt', label: 'bidirectional' },
      { code: 4, name: 'ppm', label: 'photon mapping' },
    ],
  },
  mode: {
    bytes: 1,
    values: [
      { code: 0, name: 'progressive', label: 'progressive' },
      { code: 1, name: 'atrous', label: 'À-Trous frames' },
      { code: 2, name: 'guided', label: 'guided frames' },
    ],
  },
  stream: {
    bytes: 1,
    values: [
      { code: 0, name: 'camera', label: 'camera' },
      { code: 1, name: 'light', label: 'light' },
    ],
  },
  pickTarget: {
    bytes: 1,
    values: [
      { code: 0, name: 'nothing', label: 'nothing' },
      { code: 1, name: 'object', label: 'object' },
      { code: 2, name: 'light', label: 'light' },
    ],
  },
  editOp: {
    bytes: 1,
    values: [
      { code: 0, name: 'moveInstance', label: 'move object' },
      { code: 1, name: 'moveLight', label: 'move light' },
      { code: 2, name: 'lightIntensity', label: 'light intensity' },
      { code: 3, name: 'emission', label: 'emission' },
      { code: 4, name: 'baseColor', label: 'base colour' },
    ],
  },
  errorCode: {
    bytes: 2,
    values: [
      { code: 1, name: 'malformed', label: 'malformed, wrong length' },
      { code: 2, name: 'unknownType', label: 'unknown type' },
      { code: 3, name: 'version', label: 'wrong version' },
      { code: 4, name: 'invalidValue', label: 'invalid value' },
      { code: 5, name: 'tooLarge', label: 'too large' },
      { code: 6, name: 'textMessage', label: 'text message' },
      { code: 7, name: 'unexpected', label: 'a server-only type sent by a viewer' },
    ],
  },
};

export const RECORDS = {
  HEADER: {
    bytes: 4,
    fields: {
      kind: { offset: 0, type: 'u8', bytes: 1, count: 1 },
      version: { offset: 1, type: 'u8', bytes: 1, count: 1 },
      reserved: { offset: 2, type: 'reserved', bytes: 1, count: 2 },
    },
  },
  SAMPLE: {
    bytes: 12,
    fields: {
      uv: { offset: 0, type: 'unorm16', bytes: 2, count: 2 },
      xyzw: { offset: 4, type: 'f16', bytes: 2, count: 4 },
    },
  },
};

export const MESSAGES = {
  HELLO: {
    kind: 0x01,
    direction: 'toViewer',
    bytes: 68,
    fields: {
      width: { offset: 4, type: 'u32', bytes: 4, count: 1 },
      height: { offset: 8, type: 'u32', bytes: 4, count: 1 },
      triangles: { offset: 12, type: 'u32', bytes: 4, count: 1 },
      threads: { offset: 16, type: 'u16', bytes: 2, count: 1 },
      integrator: { offset: 18, type: 'enum', enum: 'integrator', bytes: 1, count: 1 },
      mode: { offset: 19, type: 'enum', enum: 'mode', bytes: 1, count: 1 },
      sampleBytes: { offset: 20, type: 'u16', bytes: 2, count: 1 },
      epoch: { offset: 22, type: 'u32', bytes: 4, count: 1 },
      origin: { offset: 26, type: 'f32', bytes: 4, count: 3 },
      target: { offset: 38, type: 'f32', bytes: 4, count: 3 },
      up: { offset: 50, type: 'f32', bytes: 4, count: 3 },
      fov: { offset: 62, type: 'f32', bytes: 4, count: 1 },
      nameLength: { offset: 66, type: 'u16', bytes: 2, count: 1 },
      name: { offset: 68, type: 'utf8', bytes: 1, count: { factor: 1, fields: ['nameLength'] } },
    },
  },
  CAMERA: {
    kind: 0x02,
    direction: 'both',
    bytes: 48,
    fields: {
      epoch: { offset: 4, type: 'u32', bytes: 4, count: 1 },
      origin: { offset: 8, type: 'f32', bytes: 4, count: 3 },
      target: { offset: 20, type: 'f32', bytes: 4, count: 3 },
      up: { offset: 32, type: 'f32', bytes: 4, count: 3 },
      fov: { offset: 44, type: 'f32', bytes: 4, count: 1 },
    },
  },
  PARAMS: {
    kind: 0x03,
    direction: 'both',
    bytes: 8,
    fields: {
      integrator: { offset: 4, type: 'enum', enum: 'integrator', bytes: 1, count: 1 },
      mode: { offset: 5, type: 'enum', enum: 'mode', bytes: 1, count: 1 },
      reserved: { offset: 6, type: 'reserved', bytes: 1, count: 2 },
    },
  },
  ANIMATE: {
    kind: 0x04,
    direction: 'both',
    bytes: 16,
    fields: {
      playing: { offset: 4, type: 'bool', bytes: 1, count: 1 },
      reserved: { offset: 5, type: 'reserved', bytes: 1, count: 3 },
      time: { offset: 8, type: 'f32', bytes: 4, count: 1 },
      duration: { offset: 12, type: 'f32', bytes: 4, count: 1 },
    },
  },
  PICK: {
    kind: 0x05,
    direction: 'both',
    bytes: 82,
    fields: {
      request: { offset: 4, type: 'u32', bytes: 4, count: 1 },
      uv: { offset: 8, type: 'f32', bytes: 4, count: 2 },
      target: { offset: 16, type: 'enum', enum: 'pickTarget', bytes: 1, count: 1 },
      hasColor: { offset: 17, type: 'bool', bytes: 1, count: 1 },
      reserved: { offset: 18, type: 'reserved', bytes: 1, count: 2 },
      index: { offset: 20, type: 'u32', bytes: 4, count: 1 },
      mesh: { offset: 24, type: 'u32', bytes: 4, count: 1 },
      material: { offset: 28, type: 'u32', bytes: 4, count: 1 },
      position: { offset: 32, type: 'f32', bytes: 4, count: 3 },
      point: { offset: 44, type: 'f32', bytes: 4, count: 3 },
      color: { offset: 56, type: 'f32', bytes: 4, count: 3 },
      emission: { offset: 68, type: 'f32', bytes: 4, count: 3 },
      nameLength: { offset: 80, type: 'u16', bytes: 2, count: 1 },
      name: { offset: 82, type: 'utf8', bytes: 1, count: { factor: 1, fields: ['nameLength'] } },
    },
  },
  EDIT: {
    kind: 0x06,
    direction: 'both',
    bytes: 24,
    fields: {
      op: { offset: 4, type: 'enum', enum: 'editOp', bytes: 1, count: 1 },
      reserved: { offset: 5, type: 'reserved', bytes: 1, count: 3 },
      index: { offset: 8, type: 'u32', bytes: 4, count: 1 },
      value: { offset: 12, type: 'f32', bytes: 4, count: 3 },
    },
  },
  SAMPLES: {
    kind: 0x10,
    direction: 'toViewer',
    bytes: 20,
    fields: {
      epoch: { offset: 4, type: 'u32', bytes: 4, count: 1 },
      stream: { offset: 8, type: 'enum', enum: 'stream', bytes: 1, count: 1 },
      reserved: { offset: 9, type: 'reserved', bytes: 1, count: 3 },
      count: { offset: 12, type: 'u32', bytes: 4, count: 1 },
      lightPaths: { offset: 16, type: 'u32', bytes: 4, count: 1 },
      samples: { offset: 20, type: 'record', record: 'SAMPLE', bytes: 12, count: { factor: 1, fields: ['count'] } },
    },
  },
  FRAME: {
    kind: 0x11,
    direction: 'toViewer',
    bytes: 20,
    fields: {
      epoch: { offset: 4, type: 'u32', bytes: 4, count: 1 },
      width: { offset: 8, type: 'u16', bytes: 2, count: 1 },
      height: { offset: 10, type: 'u16', bytes: 2, count: 1 },
      mode: { offset: 12, type: 'enum', enum: 'mode', bytes: 1, count: 1 },
      reserved: { offset: 13, type: 'reserved', bytes: 1, count: 3 },
      frames: { offset: 16, type: 'u32', bytes: 4, count: 1 },
      pixels: { offset: 20, type: 'f16', bytes: 2, count: { factor: 4, fields: ['width', 'height'] } },
    },
  },
  STATS: {
    kind: 0x12,
    direction: 'toViewer',
    bytes: 36,
    fields: {
      epoch: { offset: 4, type: 'u32', bytes: 4, count: 1 },
      viewers: { offset: 8, type: 'u32', bytes: 4, count: 1 },
      samples: { offset: 12, type: 'u64', bytes: 8, count: 1 },
      lightPaths: { offset: 20, type: 'u64', bytes: 8, count: 1 },
      rate: { offset: 28, type: 'f32', bytes: 4, count: 1 },
      dropped: { offset: 32, type: 'u32', bytes: 4, count: 1 },
    },
  },
  FINISH: {
    kind: 0x13,
    direction: 'toViewer',
    bytes: 32,
    fields: {
      epoch: { offset: 4, type: 'u32', bytes: 4, count: 1 },
      aborted: { offset: 8, type: 'bool', bytes: 1, count: 1 },
      reserved: { offset: 9, type: 'reserved', bytes: 1, count: 3 },
      samples: { offset: 12, type: 'u64', bytes: 8, count: 1 },
      lightPaths: { offset: 20, type: 'u64', bytes: 8, count: 1 },
      seconds: { offset: 28, type: 'f32', bytes: 4, count: 1 },
    },
  },
  ERROR: {
    kind: 0x7f,
    direction: 'toViewer',
    bytes: 8,
    fields: {
      code: { offset: 4, type: 'enum', enum: 'errorCode', bytes: 2, count: 1 },
      length: { offset: 6, type: 'u16', bytes: 2, count: 1 },
      message: { offset: 8, type: 'utf8', bytes: 1, count: { factor: 1, fields: ['length'] } },
    },
  },
};
