#version 300 es
// Pass 1: adds the sample's XYZW times the normalised filter (additive blending).
precision highp float;
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
  o = v_value * (w1(d.x) * w1(d.y) * v_norm);
}
