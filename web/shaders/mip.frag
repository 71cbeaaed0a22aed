#version 300 es
// One MIP level from the one below (the only level the texture exposes while this runs):
// the mean of the 2x2 block, with the last row/column of odd sizes folded in.
precision highp float;
uniform highp sampler2D u_src;
out vec4 o;

void main() {
  ivec2 srcSize = textureSize(u_src, 0);
  ivec2 p = ivec2(gl_FragCoord.xy) * 2;
  vec4 s = vec4(0.0);
  float n = 0.0;
  int ex = (p.x + 3 == srcSize.x) ? 3 : 2;
  int ey = (p.y + 3 == srcSize.y) ? 3 : 2;
  for (int j = 0; j < ey; j++) {
    for (int i = 0; i < ex; i++) {
      ivec2 q = min(p + ivec2(i, j), srcSize - 1);
      s += texelFetch(u_src, q, 0);
      n += 1.0;
    }
  }
  o = s / n;
}
