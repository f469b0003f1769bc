"""Ashikhmin-Shirley 2000's specular lobe (isotropic and anisotropic) with Schlick's
Fresnel term (materials/src/analytic/ashikhmin_shirley.rs)."""

import math

import drjit as dr

from ..backend import dot, normalize
from .common import cosine_power_width, schlick


class AshikhminShirley:
    TYPES = ("ashikhmin-shirley", "ashikhmin-shirley-anisotropic")

    def __init__(self, d, T):
        self.T, self.f0 = T, d.get("f0", 0.05)
        if d["type"] == "ashikhmin-shirley":
            self.nu = self.nv = d.get("n", 100.0)
        else:
            self.nu, self.nv = d.get("nu", 100.0), d.get("nv", 100.0)

    def widths(self):
        return cosine_power_width(max(self.nu, self.nv)), cosine_power_width(min(self.nu, self.nv))

    def value(self, v, l):
        h = normalize(v + l)
        s2 = h.x * h.x + h.y * h.y
        e = dr.select(s2 > 1e-12, (self.nu * h.x * h.x + self.nv * h.y * h.y) / s2, self.nu)
        lh = dot(l, h)
        norm = math.sqrt((self.nu + 1) * (self.nv + 1)) / (8 * math.pi)
        val = norm * dr.power(h.z, e) * schlick(self.f0, lh) / (lh * dr.maximum(l.z, v.z))
        return self.T.gray(dr.select(lh > 0, val, 0.0))
