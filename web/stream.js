// One sample stream on the GPU (paper §4.2): an XYZW texture and a variance texture, both with
// MIP chains. Samples are splatted additively in two passes (colour, then variance against
// the updated mean), then the MIP levels are rebuilt.

import { BATCH_HEADER, SAMPLE, SAMPLE_BYTES } from './protocol.js';
import { clearTexture, levelTexture } from './gl.js';

export class SampleStream {
  constructor(gl, programs, formats, w, h) {
    this.gl = gl;
    this.p = programs;
    this.w = w;
    this.h = h;
    this.accum = levelTexture(gl, formats.rgba, w, h);
    this.variance = levelTexture(gl, formats.r, w, h);
    this.vao = gl.createVertexArray();
    this.vbo = gl.createBuffer();
    gl.bindVertexArray(this.vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.vbo);
    // The sample record's fields are the vertex attributes: uv as normalised u16, XYZW halves.
    const { uv, xyzw } = SAMPLE.fields;
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, uv.count, gl.UNSIGNED_SHORT, true, SAMPLE_BYTES, uv.offset);
    gl.enableVertexAttribArray(1);
    gl.vertexAttribPointer(1, xyzw.count, gl.HALF_FLOAT, false, SAMPLE_BYTES, xyzw.offset);
    gl.bindVertexArray(null);
    this.reset();
  }

  reset() {
    clearTexture(this.gl, this.accum);
    clearTexture(this.gl, this.variance);
    this.samples = 0;
    this.lightPaths = 0;
    this.dirty = false;
  }

  // Splats one batch message (its samples are uploaded as they came off the wire).
  splat(msg) {
    this.lightPaths += msg.lightPaths;
    if (msg.count === 0) return;
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.vbo);
    gl.bufferData(gl.ARRAY_BUFFER,
      new Uint8Array(msg.buffer, BATCH_HEADER, msg.count * SAMPLE_BYTES), gl.STREAM_DRAW);
    gl.bindVertexArray(this.vao);
    gl.viewport(0, 0, this.w, this.h);
    gl.enable(gl.BLEND);
    gl.blendFunc(gl.ONE, gl.ONE);
    gl.blendEquation(gl.FUNC_ADD);
    // Pass 1: colour.
    gl.useProgram(this.p.splat.program);
    gl.uniform2f(this.p.splat.uniforms.u_size, this.w, this.h);
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.accum.fbos[0]);
    gl.drawArrays(gl.POINTS, 0, msg.count);
    // Pass 2: variance, reading the means just updated.
    gl.useProgram(this.p.variance.program);
    gl.uniform2f(this.p.variance.uniforms.u_size, this.w, this.h);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, this.accum.tex);
    this.exposeLevel(this.accum, 0, 0);
    gl.uniform1i(this.p.variance.uniforms.u_accum, 0);
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.variance.fbos[0]);
    gl.drawArrays(gl.POINTS, 0, msg.count);
    gl.disable(gl.BLEND);
    gl.bindVertexArray(null);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    this.samples += msg.count;
    this.dirty = true;
  }

  // Restricts sampling to levels [lo, hi] (a level being rendered must not be sampled).
  exposeLevel(t, lo, hi) {
    const gl = this.gl;
    gl.bindTexture(gl.TEXTURE_2D, t.tex);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_BASE_LEVEL, lo);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAX_LEVEL, hi);
  }

  // Rebuilds the MIP chains of both textures after new samples.
  buildMips(quadVao) {
    if (!this.dirty) return;
    const gl = this.gl;
    gl.useProgram(this.p.mip.program);
    gl.uniform1i(this.p.mip.uniforms.u_src, 0);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindVertexArray(quadVao);
    for (const t of [this.accum, this.variance]) {
      for (let l = 1; l < t.levels; l++) {
        this.exposeLevel(t, l - 1, l - 1);
        const [w, h] = t.size(l);
        gl.bindFramebuffer(gl.FRAMEBUFFER, t.fbos[l]);
        gl.viewport(0, 0, w, h);
        gl.drawArrays(gl.TRIANGLES, 0, 3);
      }
      this.exposeLevel(t, 0, t.levels - 1);
    }
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.bindVertexArray(null);
    this.dirty = false;
  }

  // Base level of detail log4(P / S); the display adds the variance term.
  baseLod() {
    if (this.samples === 0) return this.accum.levels - 1;
    return 0.5 * Math.log2((this.w * this.h) / this.samples);
  }
}
