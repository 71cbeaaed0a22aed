// The repaint pass and the filtered-frame texture.

import { FRAME_HEADER } from './protocol.js';

// CIE XYZ (D65) to linear sRGB, column-major for uniformMatrix3fv.
const XYZ_TO_SRGB = new Float32Array([
  3.2404542, -0.9692660, 0.0556434,
  -1.5371385, 1.8760108, -0.2040259,
  -0.4985314, 0.0415560, 1.0572252,
]);

export class Display {
  constructor(gl, prog, w, h) {
    this.gl = gl;
    this.p = prog;
    this.w = w;
    this.h = h;
    this.frameTex = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, this.frameTex);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA16F, w, h);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    this.hasFrame = false;
    this.frames = 0;
  }

  uploadFrame(msg) {
    if (msg.width !== this.w || msg.height !== this.h) return;
    const gl = this.gl;
    gl.bindTexture(gl.TEXTURE_2D, this.frameTex);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    const px = new Uint16Array(msg.buffer, FRAME_HEADER, this.w * this.h * 4);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, this.w, this.h, gl.RGBA, gl.HALF_FLOAT, px);
    this.hasFrame = true;
    this.frames = msg.frames;
  }

  draw(quadVao, camera, light, params, frameMode) {
    const gl = this.gl;
    const u = this.p.uniforms;
    gl.useProgram(this.p.program);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, this.w, this.h);
    const bind = (unit, tex, name) => {
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, tex);
      gl.uniform1i(u[name], unit);
    };
    bind(0, camera.accum.tex, 'u_camAccum');
    bind(1, camera.variance.tex, 'u_camVar');
    bind(2, light.accum.tex, 'u_litAccum');
    bind(3, light.variance.tex, 'u_litVar');
    bind(4, this.frameTex, 'u_frame');
    gl.uniform1i(u.u_camOn, camera.samples > 0 ? 1 : 0);
    gl.uniform1i(u.u_litOn, light.samples > 0 ? 1 : 0);
    gl.uniform1i(u.u_frameOn, frameMode && this.hasFrame ? 1 : 0);
    gl.uniform1f(u.u_camLod, camera.baseLod());
    gl.uniform1f(u.u_litLod, light.baseLod());
    gl.uniform1f(u.u_lw, light.lightPaths);
    gl.uniform1i(u.u_maxLevel, camera.accum.levels - 1);
    gl.uniform1f(u.u_B, params.B);
    gl.uniform1f(u.u_C, params.C);
    gl.uniform1f(u.u_G, params.G);
    gl.uniform1f(u.u_Vm, params.Vm);
    gl.uniform1f(u.u_glare, params.glare);
    gl.uniformMatrix3fv(u.u_P, false, XYZ_TO_SRGB);
    gl.uniform2f(u.u_size, this.w, this.h);
    gl.bindVertexArray(quadVao);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    gl.bindVertexArray(null);
  }
}
