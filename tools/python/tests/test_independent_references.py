"""Models' values against implementations that are not lobe's, so that a model whose
value is wrong by a few percent fails: Mitsuba 3's own plugins (``diffuse`` for Lambert;
``roughconductor`` and ``roughdielectric`` for the Beckmann Cook-Torrance forms, whose
reflection is D G F / (4 cos_i cos_o) against Ngan et al.'s D G F / (pi cos_i cos_o), so
the ratio is 4/pi wherever both shadowing terms are 1; ``roughconductor`` for the
sampled-microfacet generator with a tabulated Beckmann p, whose p F / (4 g(k1) g(k2)) is
Walter's D F / (4 cos_i cos_o) there, g(k) = k.n for a narrow isotropic or anisotropic p)
and the normalization each model's paper states (the albedo of a narrow lobe at normal
incidence, ``NARROW``), integrated here by quadrature. Each check has a control: the same
model scaled by 1.05 must fail it.

The other models are checked independently in Rust: He et al.'s series against its
defining integral and its rough limit against Cook-Torrance with Beckmann's distribution
(materials/src/analytic/he.rs), Poulin-Fournier against brute-force ray casting of the
cylinders (poulin_fournier.rs), each to well under 5 %.

The lobe-plugin z-tests of test_mitsuba.py render lobe's own Python twins inside
Mitsuba, so they check the integrator, not the formulas; these checks do not."""

import numpy as np
import pytest

import lobe

mi = pytest.importorskip("mitsuba")
dr = pytest.importorskip("drjit")

# Directions within 30 degrees of the normal (the Smith and V-groove shadowing terms are
# both exactly 1 there for the roughness below), at several azimuths.
THETA = np.radians([0.0, 8.0, 17.0, 25.0, 30.0])
PHI = np.radians([0.0, 40.0, 135.0, 180.0, 250.0])


def pairs():
    t, p = np.meshgrid(THETA, PHI, indexing="ij")
    d = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    wi = np.repeat(d, len(d), 0)
    wo = np.tile(d, (len(d), 1))
    return wo, wi


def mitsuba_fr(bsdf, wo, wi):
    """f_r (1/sr, without the cosine) of a Mitsuba BSDF dict, scalar_rgb, one query at a
    time (Mitsuba's ``si.wi`` is lobe's ``wo``: the direction toward the viewer)."""
    mi.set_variant("scalar_rgb")
    b = mi.load_dict(bsdf)
    out = np.empty((len(wo), 3))
    for k, (o, i) in enumerate(zip(wo, wi)):
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wi = mi.Vector3f(*map(float, o))
        v = b.eval(mi.BSDFContext(), si, mi.Vector3f(*map(float, i)))
        out[k] = np.array([v[0], v[1], v[2]]) / i[2]
    return out


def lobe_fr(desc, wo, wi, scale=1.0):
    return scale * lobe.Material(desc).eval(wo.astype(np.float32), wi.astype(np.float32)).astype(np.float64)


def beckmann_conductor(**alpha):
    return {"type": "roughconductor", "distribution": "beckmann", "material": "none",
            "specular_reflectance": {"type": "rgb", "value": 0.5}, **alpha}


# (lobe's material, Mitsuba's plugin, the expected ratio, the tolerance: the generator's
# tabulated p is bilinear between 257 x 257 nodes).
CASES = {
    "lambert": ({"type": "lambert", "reflectance": [0.6, 0.4, 0.2]}, {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.6, 0.4, 0.2]}}, 1.0, 2e-4),
    "cook-torrance (Beckmann, no Fresnel)": (
        {"type": "cook-torrance", "specular": 0.5, "m": 0.3, "fresnel": "none"},
        beckmann_conductor(alpha=0.3),
        4.0 / np.pi,
        2e-4,
    ),
    "cook-torrance (Beckmann, dielectric Fresnel)": (
        {"type": "cook-torrance", "specular": 1.0, "m": 0.3, "fresnel": "dielectric", "eta": 1.7},
        {"type": "roughdielectric", "distribution": "beckmann", "alpha": 0.3, "int_ior": 1.7, "ext_ior": 1.0},
        4.0 / np.pi,
        2e-4,
    ),
    "sampled-microfacet (Beckmann p)": (
        {"type": "sampled-microfacet", "distribution": "beckmann", "alpha_x": 0.3, "alpha_y": 0.3, "specular": 0.5, "f0": 1.0},
        beckmann_conductor(alpha=0.3),
        1.0,
        2e-3,  # measured 1.0e-3
    ),
    "sampled-microfacet (anisotropic Beckmann p)": (
        {"type": "sampled-microfacet", "distribution": "beckmann", "alpha_x": 0.2, "alpha_y": 0.4, "specular": 0.5, "f0": 1.0},
        beckmann_conductor(alpha_u=0.2, alpha_v=0.4),
        1.0,
        1e-2,  # measured 7.1e-3
    ),
}


def ratio_error(desc, bsdf, expected, scale):
    wo, wi = pairs()
    a, b = lobe_fr(desc, wo, wi, scale), mitsuba_fr(bsdf, wo, wi)
    keep = b > 1e-6 * b.max()
    return float(np.max(np.abs(a[keep] / b[keep] / expected - 1.0)))


@pytest.mark.parametrize("case", sorted(CASES))
def test_model_equals_mitsubas_own_plugin(case):
    desc, bsdf, expected, tolerance = CASES[case]
    assert ratio_error(desc, bsdf, expected, 1.0) < tolerance
    # The control: 5 % off fails by far.
    assert ratio_error(desc, bsdf, expected, 1.05) > 0.04


def normal_albedo(desc, scale=1.0, n=(400, 64)):
    """The directional albedo at normal incidence by midpoint quadrature in (theta, phi),
    denser near the normal where a narrow lobe lives (theta = (pi/2) u^2)."""
    u = (np.arange(n[0]) + 0.5) / n[0]
    theta = 0.5 * np.pi * u * u
    dtheta = np.pi * u / n[0]
    phi = (np.arange(n[1]) + 0.5) * 2 * np.pi / n[1]
    t, p = np.meshgrid(theta, phi, indexing="ij")
    wi = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    wo = np.tile([[0.0, 0.0, 1.0]], (len(wi), 1))
    f = lobe_fr(desc, wo, wi, scale)[:, 1].reshape(t.shape)
    w = (np.cos(t) * np.sin(t) * dtheta[:, None] * (2 * np.pi / n[1]))
    return float(np.sum(f * w))


# Narrow lobes and the albedo at normal incidence their papers' normalization gives them:
# Ward (1992) and Duer (2005) normalize the lobe to its specular reflectance; Lafortune et
# al. (1997) the cosine lobe about its axis; Ashikhmin and Shirley (2000) to the Fresnel
# reflectance (f0 = 1 here); Blinn-Phong's (n + 2) / (2 pi) normalizes D(h) cos(theta_h),
# which a mirror-direction Jacobian of 1 / (4 h.wo) turns into 4 ks; Ngan's Cook-Torrance
# (pi in place of Walter's 4) into 4 ks / pi.
NARROW = {
    "ward": ({"type": "ward", "specular": 0.3, "alpha": 0.04}, 0.3),
    "ward-duer": ({"type": "ward-duer", "specular": 0.3, "alpha": 0.04}, 0.3),
    "ward-anisotropic": ({"type": "ward-anisotropic", "specular": 0.3, "alpha_x": 0.03, "alpha_y": 0.06}, 0.3),
    "ashikhmin-shirley-anisotropic": (
        {"type": "ashikhmin-shirley-anisotropic", "specular": 0.3, "nu": 4000, "nv": 1000, "f0": 1.0}, 0.3),
    "lafortune": ({"type": "lafortune", "specular": 0.3, "cx": -1, "cy": -1, "cz": 1, "n": 2000}, 0.3),
    "ashikhmin-shirley": ({"type": "ashikhmin-shirley", "specular": 0.3, "n": 2000, "f0": 1.0}, 0.3),
    "blinn-phong": ({"type": "blinn-phong", "specular": 0.3, "n": 2000}, 1.2),
    "cook-torrance": ({"type": "cook-torrance", "specular": 0.3, "m": 0.04, "fresnel": "none"}, 1.2 / np.pi),
}


@pytest.mark.parametrize("model", sorted(NARROW))
def test_a_narrow_lobe_reflects_what_its_normalization_says_at_normal_incidence(model):
    desc, albedo = NARROW[model]
    assert normal_albedo(desc, n=(2000, 64)) == pytest.approx(albedo, rel=0.01)
    assert normal_albedo(desc, 1.05, n=(2000, 64)) != pytest.approx(albedo, rel=0.03)
