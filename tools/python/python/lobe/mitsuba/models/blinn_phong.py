"""Blinn-Phong, Ngan et al. 2005 section 3.1: (n + 2) / (2 pi) (n.h)^n
(materials/src/analytic/blinn_phong.rs)."""

import math

import drjit as dr

from ..backend import normalize
from .common import cosine_power_width


class BlinnPhong:
    TYPES = ("blinn-phong",)

    def __init__(self, d, T):
        self.T, self.n = T, d.get("n", 100.0)

    def widths(self):
        a = cosine_power_width(self.n)
        return a, min(1.0, 3 * a)

    def value(self, v, l):
        h = normalize(v + l)
        return self.T.gray((self.n + 2) / (2 * math.pi) * dr.power(dr.maximum(h.z, 0.0), self.n))
