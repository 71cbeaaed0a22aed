#version 300 es
// Pass 2 (after pass 1 updated the means): adds w·(Y − Ȳ)² with Ȳ the texel's current mean
// luminance — the paper's running update V_j = V_{j-1} + Σ (Y_i − Ȳ)². Never a sum of squares.
precision highp float;
uniform highp sampler2D u_accum;
in vec4 v_value;
flat in vec2 v_center;
flat in float v_norm;
out vec4 o;

const float R = 2.5;
const float SIGMA = 0.7;

float w1(float d) {
  float g = exp(-d * d / (2.0 * SIGMA * SIGMA));
  return g * (1.0 - pow(smoothstep(0.0, R, abs(d)), 8.0));
}

void main() {
  vec2 d = gl_FragCoord.xy - v_center;
  float w = w1(d.x) * w1(d.y) * v_norm;
  vec4 t = texelFetch(u_accum, ivec2(gl_FragCoord.xy), 0);
  float mean = t.w > 0.0 ? t.y / t.w : 0.0;
  float dy = v_value.y / max(v_value.w, 1e-6) - mean;
  o = vec4(w * dy * dy, 0.0, 0.0, 0.0);
}
