#version 300 es
// Repaint (paper §4.2-4.3): per stream, LoD' = log4(P/S) + Vm·log4(Var); a windowed Gaussian
// blur on the two nearest MIP levels, blended linearly; normalisation (camera: XYZ/W, light:
// XYZ/Lw); tone map Y' = 1 − exp(−(B·Y)^C); XYZ → RGB by P; desaturation into the gamut
// keeping luminance; gamma G. Optional glare (step 5 of the paper's algorithm) between the
// normalisation and the tone map.
precision highp float;
precision highp int;

uniform highp sampler2D u_camAccum;
uniform highp sampler2D u_camVar;
uniform highp sampler2D u_litAccum;
uniform highp sampler2D u_litVar;
uniform highp sampler2D u_frame;
uniform bool u_camOn;
uniform bool u_litOn;
uniform bool u_frameOn;
uniform float u_camLod;   // log4(P / S_camera)
uniform float u_litLod;   // log4(P / S_light)
uniform float u_lw;       // light paths
uniform int u_maxLevel;
uniform float u_B;
uniform float u_C;
uniform float u_G;
uniform float u_Vm;
uniform float u_glare;    // fraction of the light scattered by the glare PSF; 0 = off
uniform mat3 u_P;         // XYZ -> display RGB
uniform vec2 u_size;
out vec4 o;

const float R = 2.5;   // truncation radius, texels of the level
const float E = 8.0;   // window exponent
const float T = 1.0;   // sigma threshold t

float windowed(float d2, float sigma) {
  float d = sqrt(d2);
  return exp(-sigma * d2) * (1.0 - pow(smoothstep(0.0, R, d), E));
}

// Gaussian exp(-sigma d²) (d in texels of `level`) around uv, truncated at R and windowed.
vec4 blur(highp sampler2D t, int level, float sigma, vec2 uv) {
  ivec2 size = textureSize(t, level);
  vec2 p = uv * vec2(size);
  ivec2 base = ivec2(floor(p));
  vec4 acc = vec4(0.0);
  float ws = 0.0;
  for (int j = -3; j <= 3; j++) {
    for (int i = -3; i <= 3; i++) {
      ivec2 q = base + ivec2(i, j);
      if (q.x < 0 || q.y < 0 || q.x >= size.x || q.y >= size.y) continue;
      vec2 d = vec2(q) + 0.5 - p;
      float d2 = dot(d, d);
      if (d2 >= R * R) continue;
      float g = windowed(d2, sigma);
      acc += g * texelFetch(t, q, level);
      ws += g;
    }
  }
  return ws > 0.0 ? acc / ws : vec4(0.0);
}

// Variance of luminance (display units, B·Y) at a level: V/(n−1) from the MIP averages.
float variance(highp sampler2D vt, highp sampler2D at, float lod, vec2 uv) {
  int l = clamp(int(floor(lod)), 0, u_maxLevel);
  ivec2 q = ivec2(uv * vec2(textureSize(vt, l)));
  float v = texelFetch(vt, q, l).x;
  float w = texelFetch(at, q, l).w;
  float n1 = w - exp2(-2.0 * float(l));  // Σw − 1, divided by the 4^l texels averaged
  return n1 > 0.0 ? v / n1 * u_B * u_B : 1.0;
}

// A stream's filtered XYZW at uv.
vec4 reconstruct(highp sampler2D at, highp sampler2D vt, float baseLod, vec2 uv) {
  float var = variance(vt, at, max(baseLod, 0.0), uv);
  float lod = baseLod + u_Vm * 0.5 * log2(max(var, 1e-12));
  lod = clamp(lod, -1.0, float(u_maxLevel));
  if (lod <= 0.0) {
    // More samples than pixels: sharpen at level 0 (sigma grows above t).
    return blur(at, 0, T * exp2(-2.0 * lod), uv);
  }
  int lo = int(floor(lod));
  int hi = min(lo + 1, u_maxLevel);
  float f = lod - float(lo);
  // sigma at level l for a blur of "lod" levels: t · 4^(l − lod).
  vec4 a = blur(at, lo, T * exp2(2.0 * (float(lo) - lod)), uv);
  vec4 b = blur(at, hi, T * exp2(2.0 * (float(hi) - lod)), uv);
  return mix(a, b, f);
}

// The normalised radiance of both streams at a MIP level, smoothed by a one-texel Gaussian.
vec3 levelRadiance(int level, vec2 uv) {
  vec3 xyz = vec3(0.0);
  if (u_camOn) {
    vec4 c = blur(u_camAccum, level, T, uv);
    if (c.w > 1e-8) xyz += c.xyz / c.w;
  }
  if (u_litOn && u_lw > 0.0) xyz += blur(u_litAccum, level, T, uv).xyz / u_lw;
  return xyz;
}

// Glare as a convolution with a point-spread function built from the MIP chain: level k
// averages 2^k × 2^k pixels, so weighting it by 2^-k puts equal-ratio energy into every octave
// of distance — the r^-3 fall-off of the wide-angle part of the eye's PSF (Spencer et al.
// 1995, the paper's [20]) without a large convolution at display rate. The weights sum to one,
// so glare only moves light around and the image's total energy is kept.
vec3 glare(vec2 uv) {
  vec3 g = vec3(0.0);
  float ws = 0.0;
  for (int k = 1; k <= 7; k++) {
    if (k > u_maxLevel) break;
    float a = exp2(-float(k));
    g += a * levelRadiance(k, uv);
    ws += a;
  }
  return ws > 0.0 ? g / ws : vec3(0.0);
}

vec3 toneMap(vec3 xyz) {
  float y = xyz.y;
  if (!(y > 0.0)) return vec3(0.0);
  float yt = 1.0 - exp(-pow(u_B * y, u_C));
  return xyz * (yt / y);
}

// Desaturate towards the grey of equal luminance until every channel is in [0, 1].
vec3 gamutMap(vec3 rgb, float y) {
  float s = 1.0;
  for (int i = 0; i < 3; i++) {
    float c = rgb[i];
    if (c < 0.0) s = min(s, y / (y - c));
    if (c > 1.0) s = min(s, (1.0 - y) / (c - y));
  }
  return clamp(vec3(y) + s * (rgb - vec3(y)), 0.0, 1.0);
}

void main() {
  vec2 uv = gl_FragCoord.xy / u_size;
  vec3 xyz = vec3(0.0);
  if (u_frameOn) {
    // Frames arrive top row first; GL's row 0 is the bottom.
    ivec2 q = ivec2(gl_FragCoord.xy);
    xyz = texelFetch(u_frame, ivec2(q.x, int(u_size.y) - 1 - q.y), 0).xyz;
  } else {
    if (u_camOn) {
      vec4 c = reconstruct(u_camAccum, u_camVar, u_camLod, uv);
      if (c.w > 1e-8) xyz += c.xyz / c.w;
    }
    if (u_litOn && u_lw > 0.0) {
      xyz += reconstruct(u_litAccum, u_litVar, u_litLod, uv).xyz / u_lw;
    }
    if (u_glare > 0.0) xyz = mix(xyz, glare(uv), u_glare);
  }
  vec3 t = toneMap(max(xyz, vec3(0.0)));
  vec3 rgb = gamutMap(u_P * t, t.y);
  o = vec4(pow(rgb, vec3(1.0 / u_G)), 1.0);
}
