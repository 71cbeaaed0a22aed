// Small WebGL2 helpers: shader programs, float textures with MIP levels, framebuffers.

export async function loadText(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: ${r.status}`);
  return r.text();
}

export function program(gl, vsSrc, fsSrc) {
  const compile = (type, src) => {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) {
      throw new Error(`shader: ${gl.getShaderInfoLog(s)}`);
    }
    return s;
  };
  const p = gl.createProgram();
  gl.attachShader(p, compile(gl.VERTEX_SHADER, vsSrc));
  gl.attachShader(p, compile(gl.FRAGMENT_SHADER, fsSrc));
  gl.linkProgram(p);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
  const uniforms = {};
  const n = gl.getProgramParameter(p, gl.ACTIVE_UNIFORMS);
  for (let i = 0; i < n; i++) {
    const name = gl.getActiveUniform(p, i).name;
    uniforms[name] = gl.getUniformLocation(p, name);
  }
  return { program: p, uniforms };
}

// Float render targets: RGBA32F needs EXT_color_buffer_float, and additive blending into it
// needs EXT_float_blend; without the latter, half floats (always blendable) are used.
export function floatFormats(gl) {
  if (!gl.getExtension('EXT_color_buffer_float')) {
    throw new Error('this browser cannot render to float textures (EXT_color_buffer_float)');
  }
  const full = !!gl.getExtension('EXT_float_blend');
  return full
    ? { rgba: gl.RGBA32F, r: gl.R32F, precision: 'float32' }
    : { rgba: gl.RGBA16F, r: gl.R16F, precision: 'float16' };
}

export function mipLevels(w, h) {
  return Math.floor(Math.log2(Math.max(w, h))) + 1;
}

// An immutable texture with all MIP levels and one framebuffer per level. Sampling uses
// texelFetch only, so NEAREST filtering suffices (float32 is not filterable everywhere).
export function levelTexture(gl, internalFormat, w, h) {
  const levels = mipLevels(w, h);
  const tex = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, tex);
  gl.texStorage2D(gl.TEXTURE_2D, levels, internalFormat, w, h);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST_MIPMAP_NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
  const fbos = [];
  for (let l = 0; l < levels; l++) {
    const fb = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, l);
    const status = gl.checkFramebufferStatus(gl.FRAMEBUFFER);
    if (status !== gl.FRAMEBUFFER_COMPLETE) throw new Error(`framebuffer incomplete: ${status}`);
    fbos.push(fb);
  }
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  const size = (l) => [Math.max(1, w >> l), Math.max(1, h >> l)];
  return { tex, fbos, levels, size, w, h };
}

export function clearTexture(gl, t) {
  gl.clearColor(0, 0, 0, 0);
  for (let l = 0; l < t.levels; l++) {
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.fbos[l]);
    gl.clear(gl.COLOR_BUFFER_BIT);
  }
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
}
