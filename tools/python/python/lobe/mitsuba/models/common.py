"""Terms the Dr.Jit model twins share (docs/models.md): Fresnel (Schlick's and the exact
dielectric), erfc, the Gaussian distribution's normalization, the He model's wavelengths,
and the Beckmann width of a cosine power (used for the half-vector proposals)."""

import math

import drjit as dr
import numpy as np

LAMBDA_UM = (0.645, 0.526, 0.444)


def rgb(v):
    """A colour parameter (a number or three) as three floats."""
    if isinstance(v, (int, float)):
        return [float(v)] * 3
    return [float(x) for x in v]


def schlick(f0, c):
    m = dr.clip(1.0 - c, 0.0, 1.0)
    return f0 + (1.0 - f0) * (m * m) * (m * m) * m


def fresnel_dielectric(eta, c):
    c = dr.clip(c, 0.0, 1.0)
    g2 = eta * eta + c * c - 1.0
    g = dr.sqrt(dr.maximum(g2, 0.0))
    a = (g - c) / (g + c)
    b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    f = 0.5 * a * a * (1.0 + b * b)
    return dr.select(g2 <= 0.0, 1.0, dr.clip(f, 0.0, 1.0))


def erfc(x):
    return 1.0 - dr.erf(x)


def gaussian_norm(m):
    """1 / (2 pi int exp(-(t/m)^2) cos t sin t dt): the Gaussian D's normalization."""
    t = np.linspace(0.0, min(math.pi / 2, 12 * m), 20001)
    f = np.exp(-(t / m) ** 2) * np.cos(t) * np.sin(t)
    integral = np.sum((f[1:] + f[:-1]) * 0.5 * (t[1] - t[0]))
    return float(1.0 / (2 * math.pi * integral))


def cosine_power_width(n):
    """The Beckmann width sqrt(2 / (n + 2)) of a cosine power n."""
    return math.sqrt(2.0 / (n + 2.0))
