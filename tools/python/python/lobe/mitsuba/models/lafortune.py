"""Lafortune et al. 1997's generalized cosine lobe (Cx lx vx + Cy ly vy + Cz lz vz)^n, with
Ngan et al. 2005's normalization or raw (materials/src/analytic/lafortune.rs)."""

import math

import drjit as dr

from .common import cosine_power_width


class Lafortune:
    TYPES = ("lafortune",)

    def __init__(self, d, T):
        self.T = T
        self.c = (d.get("cx", -0.577), d.get("cy", -0.577), d.get("cz", 0.577))
        self.n = d.get("n", 100.0)
        self.ngan = d.get("normalization", "ngan") == "ngan"

    def widths(self):
        a = cosine_power_width(4.0 * self.n)
        return a, min(1.0, 3 * a)

    def value(self, v, l):
        (cx, cy, cz), n = self.c, self.n
        s = cx * l.x * v.x + cy * l.y * v.y + cz * l.z * v.z
        if self.ngan:
            cmax = max(abs(cx), abs(cy), abs(cz))
            return self.T.gray((n + 2) / (2 * math.pi) * dr.power(dr.clip(s / cmax, 0.0, 1.0), n))
        return self.T.gray(dr.power(dr.maximum(s, 0.0), n))
