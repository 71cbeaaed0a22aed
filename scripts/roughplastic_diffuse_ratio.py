#!/usr/bin/env python3
"""How much brighter lumo's rough-plastic diffuse layer is than Mitsuba 3's `roughplastic`.

Both put a Lambertian base under a dielectric coat and scale it by the coat's transmittance
in and out and by 1 / (1 - internal reflectance). lumo uses the smooth coat's values
(1 - Fresnel(cos), and the hemispherical internal Fresnel reflectance), as Mitsuba's smooth
`plastic` does. Mitsuba's `roughplastic` precomputes them for the rough coat: the
transmittance is 1 minus the directional albedo of the GGX reflection lobe, and the internal
reflectance is the cosine-weighted mean of that albedo seen from inside (eta inverted).
This script integrates both numerically for a given alpha and eta and prints the ratio of the
diffuse layers for a few viewing angles (see docs/mitsuba-materials.md).

    python3 scripts/roughplastic_diffuse_ratio.py --alpha 0.15 --eta 1.5
"""

from __future__ import annotations

import argparse

import numpy as np


def fresnel(c, eta):
    """Unpolarised dielectric Fresnel reflectance for cos(incidence) c > 0, eta = n_t / n_i."""
    s2 = (1 - c * c) / (eta * eta)
    ct = np.sqrt(np.clip(1 - s2, 0, 1))
    rs = (c - eta * ct) / (c + eta * ct)
    rp = (eta * c - ct) / (eta * c + ct)
    return np.where(s2 >= 1, 1.0, 0.5 * (rs * rs + rp * rp))


def ggx_d(cos_h, a):
    c2 = cos_h**2
    t = (1 - c2) / c2
    return 1 / (np.pi * a * a * c2 * c2 * (1 + t / (a * a)) ** 2)


def smith_g1(cos_v, a):
    c2 = np.clip(cos_v**2, 1e-12, 1)
    return 2 / (1 + np.sqrt(1 + a * a * (1 - c2) / c2))


def reflection_albedo(mu, eta, a, n=1200):
    """Directional albedo of the GGX reflection lobe (separable Smith G) at cos(view) mu.

    Integrated over half vectors (d omega_o = 4 (wi . h) d omega_h), with a polar grid
    that is dense where D is large."""
    wi = np.array([np.sqrt(1 - mu * mu), 0.0, mu])
    u = (np.arange(n) + 0.5) / n
    th = np.arctan(a * np.tan(u * np.pi / 2 * 0.9999))
    dth = np.gradient(th)
    ph = (np.arange(n) + 0.5) / n * 2 * np.pi
    TH, PH = np.meshgrid(th, ph, indexing="ij")
    h = np.stack([np.sin(TH) * np.cos(PH), np.sin(TH) * np.sin(PH), np.cos(TH)], -1)
    dw = np.sin(TH) * dth[:, None] * (2 * np.pi / n)
    ih = h @ wi
    wo_z = 2 * ih * h[..., 2] - wi[2]
    ok = (ih > 0) & (wo_z > 0)
    f = fresnel(np.clip(ih, 1e-9, 1), eta) * ggx_d(h[..., 2], a)
    val = f * smith_g1(mu, a) * smith_g1(wo_z, a) * ih / mu
    return float(np.sum(np.where(ok, val * dw, 0.0)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--alpha", type=float, default=0.15)
    ap.add_argument("--eta", type=float, default=1.5)
    args = ap.parse_args()
    a, eta = args.alpha, args.eta
    mus = np.linspace(1e-3, 1, 64)  # Mitsuba tabulates 64 cosines too
    t_rough = 1 - np.array([reflection_albedo(m, eta, a) for m in mus])
    r_int_rough = 2 * float(np.mean(np.array([reflection_albedo(m, 1 / eta, a) for m in mus]) * mus))
    t_smooth = 1 - fresnel(mus, eta)
    fine = (np.arange(20000) + 0.5) / 20000  # the smooth value has a kink at total reflection
    r_int_smooth = 2 * float(np.mean(fresnel(fine, 1 / eta) * fine))
    print(f"alpha {a}, eta {eta}")
    print(f"internal reflectance: smooth (lumo) {r_int_smooth:.4f}, rough (Mitsuba) {r_int_rough:.4f}")
    for m in (0.1, 0.3, 0.5, 1.0):
        i = int(np.argmin(abs(mus - m)))
        print(f"transmittance at cos {mus[i]:.2f}: smooth {t_smooth[i]:.4f}, rough {t_rough[i]:.4f}")
    # Diffuse layer albedo for light from cos_i, integrated over cosine-weighted outgoing cos.
    mean_out = lambda t: float(np.mean(t * 2 * mus))  # noqa: E731
    for m in (0.3, 0.7, 0.95):
        i = int(np.argmin(abs(mus - m)))
        lumo = t_smooth[i] * mean_out(t_smooth) / (1 - r_int_smooth)
        mitsuba = t_rough[i] * mean_out(t_rough) / (1 - r_int_rough)
        print(f"diffuse layer at cos {m}: lumo / Mitsuba = {lumo / mitsuba:.4f}")


if __name__ == "__main__":
    main()
