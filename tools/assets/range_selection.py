#!/usr/bin/env python3
"""Would a range-aware light-selection weight lower next-event estimation's noise? (issue 48)

lumo picks the light for a light sample in proportion to its unranged power (4π I for a point
light), whatever its KHR_lights_punctual `range`. This computes, exactly rather than by
sampling, the variance that the *choice of light* adds to one light sample on a Lambertian
floor (z = 0, [-5, 5]², 400² points, no occlusion) lit by point lights with glTF's range window,
for three selection pmfs:

* power: lumo's (one table for every shading point);
* delivered flux: one table by the flux each light actually lands on the floor, window
  included (what a global range-aware weight can at best estimate);
* per-point reach: at each shading point, only the lights whose range reaches it, by power
  (a pmf that depends on the shading point).

For a pmf p the one-sample estimator f_i / p_i (light i drawn with probability p_i) has variance Σ_i f_i² / p_i − F² at a
point whose lights give f_i (F = Σ f_i). Reported: the mean over lit points of the relative
variance var / F², the image-wide Σ var / Σ F², and the share of points where the pmf is
worse than power. Needs numpy only:

    python3 tools/assets/range_selection.py
"""
import numpy as np

N = 400
XS = (np.arange(N) + 0.5) / N * 10 - 5
X, Y = np.meshgrid(XS, XS)
P = np.stack([X, Y, np.zeros_like(X)], -1)


def window(d, r):
    """glTF's recommended range window, clamp(1 − (d/r)⁴, 0, 1) (lumo_scene::range_window)."""
    return np.ones_like(d) if r is None else np.clip(1 - (d / r) ** 4, 0, 1)


def irradiance(pos, intensity, r):
    v = np.array(pos) - P
    d = np.linalg.norm(v, axis=-1)
    return intensity * window(d, r) * (v[..., 2] / d) / d**2


def variances(lights):
    f = np.stack([irradiance(p, i, r) for p, i, r in lights])
    F = f.sum(0)
    power = np.array([4 * np.pi * i for _, i, _ in lights])
    delivered = f.reshape(len(lights), -1).sum(1)
    out = {}
    for name, w in [("power", power), ("delivered flux", delivered)]:
        p = (w / w.sum())[:, None, None]
        out[name] = (f**2 / p).sum(0) - F**2
    reach = f > 0
    w = power[:, None, None] * reach
    p = np.where(reach, w / np.maximum(w.sum(0), 1e-30), 1.0)
    out["per-point reach"] = np.where(reach, f**2 / p, 0.0).sum(0) - F**2
    return F, out


SCENES = [
    ("bright short-range (I 100, range 1.5, 0.5 above) + dim unlimited (I 1, 3 above)",
     [((-2, 0, 0.5), 100.0, 1.5), ((2, 0, 3), 1.0, None)]),
    ("the same, the dim light with range 8",
     [((-2, 0, 0.5), 100.0, 1.5), ((2, 0, 3), 1.0, 8.0)]),
    ("two bright short-range + a moderate unlimited one (I 20)",
     [((-2, 0, 0.5), 100.0, 1.5), ((-1.5, 0, 0.5), 100.0, 1.5), ((2, 0, 3), 20.0, None)]),
    ("two equal lights (I 10, 1 above) whose ranges (6) cover the floor",
     [((-2, 0, 1.0), 10.0, 6.0), ((2, 0, 1.0), 10.0, 6.0)]),
]


def main():
    for label, lights in SCENES:
        F, out = variances(lights)
        lit = F > 0
        base = out["power"][lit]
        print(label)
        for name, var in out.items():
            v = var[lit]
            print(f"  {name:16s} mean var/F² {np.mean(v / F[lit] ** 2):9.3f}   "
                  f"Σvar/ΣF² {v.sum() / (F[lit] ** 2).sum():7.4f}   "
                  f"points worse than power {np.mean(v > base * 1.0001):5.1%}")


if __name__ == "__main__":
    main()
