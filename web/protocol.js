// The binary protocol of docs/protocol.md (mirror of crates/lumo-server/src/protocol.rs).
// Every message: [type u8][version u8][reserved u16], then a little-endian payload.

export const VERSION = 1;
export const SAMPLE_BYTES = 12;
export const BATCH_HEADER = 20;
export const FRAME_HEADER = 20;

export const KIND = {
  HELLO: 0x01, CAMERA: 0x02, PARAMS: 0x03, SAMPLES: 0x10, FRAME: 0x11,
  STATS: 0x12, FINISH: 0x13, ERROR: 0x7f,
};

// ERROR codes with which the server refuses a CAMERA: malformed (1), invalid value (4), too
// large (5). The server answers every CAMERA a viewer sends, in order, with a CAMERA (taken)
// or an ERROR (refused); the viewer's PARAMS come from its own menus and are always valid.
export const CAMERA_REFUSAL_CODES = new Set([1, 4, 5]);

// The viewer's count of CAMERA messages in flight after an ERROR with `code`: one fewer when
// the error refuses a camera and one is in flight. Without this, a refused camera stayed in
// flight for ever and the viewer ignored every sample until the next CAMERA arrived.
export function camerasInFlightAfterError(inflight, code) {
  return inflight > 0 && CAMERA_REFUSAL_CODES.has(code) ? inflight - 1 : inflight;
}

export const INTEGRATORS = ['path', 'light', 'both'];
export const MODES = ['progressive', 'atrous', 'guided'];

function readCamera(dv, o) {
  const f = (i) => dv.getFloat32(o + 4 + 4 * i, true);
  return {
    epoch: dv.getUint32(o, true),
    camera: {
      origin: [f(0), f(1), f(2)], target: [f(3), f(4), f(5)], up: [f(6), f(7), f(8)], fov: f(9),
    },
  };
}

// Decodes a server message (an ArrayBuffer). Sample and frame payloads stay in the buffer:
// the viewer uploads them to the GPU as they are.
export function decode(buf) {
  const dv = new DataView(buf);
  if (buf.byteLength < 4) throw new Error('short message');
  const kind = dv.getUint8(0);
  if (dv.getUint8(1) !== VERSION) throw new Error(`protocol version ${dv.getUint8(1)}`);
  switch (kind) {
    case KIND.HELLO: {
      // Offset 20 holds the bytes per sample (12), checked below.
      const cam = readCamera(dv, 22);
      const nameLen = dv.getUint16(66, true);
      const name = new TextDecoder().decode(new Uint8Array(buf, 68, nameLen));
      if (dv.getUint16(20, true) !== SAMPLE_BYTES) throw new Error('unexpected sample size');
      return {
        kind, width: dv.getUint32(4, true), height: dv.getUint32(8, true),
        triangles: dv.getUint32(12, true), threads: dv.getUint16(16, true),
        integrator: INTEGRATORS[dv.getUint8(18)], mode: MODES[dv.getUint8(19)],
        epoch: cam.epoch, camera: cam.camera, name,
      };
    }
    case KIND.CAMERA: return { kind, ...readCamera(dv, 4) };
    case KIND.PARAMS:
      return { kind, integrator: INTEGRATORS[dv.getUint8(4)], mode: MODES[dv.getUint8(5)] };
    case KIND.SAMPLES:
      return {
        kind, epoch: dv.getUint32(4, true), stream: dv.getUint8(8),
        count: dv.getUint32(12, true), lightPaths: dv.getUint32(16, true), buffer: buf,
      };
    case KIND.FRAME:
      return {
        kind, epoch: dv.getUint32(4, true), width: dv.getUint16(8, true),
        height: dv.getUint16(10, true), mode: MODES[dv.getUint8(12)],
        frames: dv.getUint32(16, true), buffer: buf,
      };
    case KIND.STATS:
      return {
        kind, epoch: dv.getUint32(4, true), viewers: dv.getUint32(8, true),
        samples: Number(dv.getBigUint64(12, true)), lightPaths: Number(dv.getBigUint64(20, true)),
        rate: dv.getFloat32(28, true), dropped: dv.getUint32(32, true),
      };
    case KIND.FINISH:
      return {
        kind, epoch: dv.getUint32(4, true), aborted: dv.getUint8(8) !== 0,
        samples: Number(dv.getBigUint64(12, true)), seconds: dv.getFloat32(28, true),
      };
    case KIND.ERROR: {
      const len = dv.getUint16(6, true);
      return {
        kind, code: dv.getUint16(4, true),
        message: new TextDecoder().decode(new Uint8Array(buf, 8, len)),
      };
    }
    default: throw new Error(`unknown message type ${kind}`);
  }
}

export function encodeCamera(c) {
  const dv = new DataView(new ArrayBuffer(48));
  dv.setUint8(0, KIND.CAMERA);
  dv.setUint8(1, VERSION);
  const v = [...c.origin, ...c.target, ...c.up, c.fov];
  v.forEach((x, i) => dv.setFloat32(8 + 4 * i, x, true));
  return dv.buffer;
}

export function encodeParams(integrator, mode) {
  const b = new Uint8Array([KIND.PARAMS, VERSION, 0, 0,
    INTEGRATORS.indexOf(integrator), MODES.indexOf(mode), 0, 0]);
  return b.buffer;
}
