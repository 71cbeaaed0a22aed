#version 300 es
// One sample as a 5x5-texel point sprite. The filter is a separable windowed Gaussian; its
// weights over the exact texels the sprite covers are summed here so that every sample adds
// exactly its value (the paper's normalised filter texture, computed instead of looked up).
layout(location = 0) in vec2 a_uv;    // unorm16, v down
layout(location = 1) in vec4 a_xyzw;  // half floats
uniform vec2 u_size;                  // level-0 texels
out vec4 v_value;
flat out vec2 v_center;
flat out float v_norm;

const float R = 2.5;
const float SIGMA = 0.7;

float w1(float d) {
  float g = exp(-d * d / (2.0 * SIGMA * SIGMA));
  return g * (1.0 - pow(smoothstep(0.0, R, abs(d)), 8.0));
}

float axisSum(float c) {
  // Texel centres i + 0.5 in [c - 2.5, c + 2.5).
  float i0 = ceil(c - 3.0);
  float s = 0.0;
  for (int k = 0; k < 5; k++) s += w1(i0 + float(k) + 0.5 - c);
  return s;
}

void main() {
  vec2 c = vec2(a_uv.x, 1.0 - a_uv.y) * u_size;  // GL's y points up
  v_center = c;
  v_norm = 1.0 / max(axisSum(c.x) * axisSum(c.y), 1e-6);
  v_value = a_xyzw;
  gl_Position = vec4(c / u_size * 2.0 - 1.0, 0.0, 1.0);
  gl_PointSize = 5.0;
}
