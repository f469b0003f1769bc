"""Cook-Torrance 1982 with the Beckmann, Gaussian or cosine-power distribution, the V-groove
G and Schlick's, the exact dielectric or no Fresnel term, as Ngan et al. 2005 section 3.1
write it (materials/src/analytic/cook_torrance.rs)."""

import math

import drjit as dr

from ..backend import dot, normalize
from .common import fresnel_dielectric, gaussian_norm, schlick


class CookTorrance:
    TYPES = ("cook-torrance",)

    def __init__(self, d, T):
        self.T, self.d = T, d
        self.m = d.get("m", 0.2)
        self.dist = d.get("distribution", "beckmann")
        self.fres = d.get("fresnel", "schlick")
        self.gnorm = gaussian_norm(self.m) if self.dist == "gaussian" else 0.0
        self.ncp = max(2.0 / (self.m * self.m) - 2.0, 0.0)

    def widths(self):
        return self.m, min(1.0, 3 * self.m)

    def _d(self, ch):
        if self.dist == "beckmann":
            c2 = ch * ch
            return dr.exp(-(1 - c2) / c2 / (self.m * self.m)) / (math.pi * self.m * self.m * c2 * c2)
        if self.dist == "gaussian":
            th = dr.acos(dr.clip(ch, -1, 1))
            return self.gnorm * dr.exp(-(th / self.m) ** 2)
        return (self.ncp + 2) / (2 * math.pi) * dr.power(dr.maximum(ch, 0.0), self.ncp)

    def _f(self, c):
        if self.fres == "none":
            return 1.0
        if self.fres == "schlick":
            return schlick(self.d.get("f0", 0.04), c)
        return fresnel_dielectric(self.d.get("eta", 1.5), c)

    def value(self, v, l):
        cv, cl = v.z, l.z
        h = normalize(v + l)
        ch, vh = h.z, dot(v, h)
        G = dr.minimum(1.0, dr.minimum(2 * ch * cv / vh, 2 * ch * cl / vh))
        val = self._d(ch) * G * self._f(dot(l, h)) / (math.pi * cl * cv)
        return self.T.gray(dr.select(ch > 0, val, 0.0))
