"""Ward 1992 (isotropic and anisotropic) and Ward-Duer (Duer 2005's normalization), as
Ngan et al. 2005 section 3.1 write them (materials/src/analytic/ward.rs, ward_duer.rs)."""

import math

import drjit as dr

# Ward-Duer's cosines are floored at cos(89 deg), as lobe's.
DUER_FLOOR = 0.0174524064372835


class Ward:
    TYPES = ("ward", "ward-duer", "ward-anisotropic")

    def __init__(self, d, T):
        self.T, self.duer = T, d["type"] == "ward-duer"
        if d["type"] == "ward-anisotropic":
            self.ax, self.ay = d.get("alpha_x", 0.1), d.get("alpha_y", 0.1)
        else:
            self.ax = self.ay = d.get("alpha", 0.1)

    def widths(self):
        a = min(self.ax, self.ay)
        return a, max(max(self.ax, self.ay), 3 * a)

    def value(self, v, l):
        hu = v + l
        e = dr.exp(-(hu.x * hu.x / (self.ax * self.ax) + hu.y * hu.y / (self.ay * self.ay)) / (hu.z * hu.z))
        if self.duer:
            cosines = dr.maximum(l.z, DUER_FLOOR) * dr.maximum(v.z, DUER_FLOOR)
        else:
            cosines = dr.sqrt(l.z * v.z)
        return self.T.gray(e / (4 * math.pi * self.ax * self.ay * cosines))
