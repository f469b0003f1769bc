"""Poulin and Fournier 1990's cylinders (lobe's reconstruction, docs/models.md;
materials/src/analytic/poulin_fournier.rs)."""

import math

import drjit as dr
import numpy as np

from ..backend import dot
from .common import cosine_power_width


class PoulinFournier:
    TYPES = ("poulin-fournier",)

    def __init__(self, d, T):
        self.T, self.d = T, d

    def widths(self):
        return cosine_power_width(self.d.get("n", 100.0)), 0.5

    def value(self, v, l):
        return self.T.gray(self._value(v, l, v.z, l.z))

    def _value(self, v, l, cv, cl):
        n, dgap, hh = self.d.get("n", 100.0), self.d.get("d", 0.5), self.d.get("h", 0.5)
        P = 2.0 + dgap
        phib = math.acos(-hh)
        uf = math.sqrt(max(1 - hh * hh, 0.0))

        def arc(a):
            s = P * dr.cos(a) - 1.0
            beta = dr.asin(dr.clip(s, -1.0, 1.0))
            lo_pos = dr.maximum(a - math.pi / 2, -phib)
            hi_pos = dr.minimum(dr.minimum(a + math.pi / 2, phib), a + beta)
            lo_neg = dr.maximum(dr.maximum(a - math.pi / 2, -phib), a - beta)
            hi_neg = dr.minimum(a + math.pi / 2, phib)
            pos = a >= 0
            return dr.select(pos, lo_pos, lo_neg), dr.select(pos, hi_pos, hi_neg)

        def flat(a):
            sa, ca = dr.sin(a), dr.cos(a)
            left = dr.select(hh - sa > 0, (1 - hh * sa) / ca, uf)
            right = dr.select(hh + sa > 0, P - (1 + hh * sa) / ca, P - uf)
            return dr.maximum(left, uf), dr.minimum(right, P - uf)

        av, nv = dr.atan2(v.y, v.z), dr.sqrt(v.y * v.y + v.z * v.z)
        al, nl = dr.atan2(l.y, l.z), dr.sqrt(l.y * l.y + l.z * l.z)
        lo1, hi1 = arc(av)
        lo2, hi2 = arc(al)
        lo, hi = dr.maximum(lo1, lo2), dr.minimum(hi1, hi2)
        A, B = nv * nl, v.x * l.x
        beta = av + al
        # Integrate over the whole visible-and-lit interval with a fine composite
        # Gauss-Legendre rule (8 panels of 16 points): independent of lobe's peak windows.
        xs, ws = np.polynomial.legendre.leggauss(16)
        panels = 8
        acc = self.T.Float(0.0)
        width = dr.maximum(hi - lo, 0.0)
        for k in range(panels):
            a0 = lo + width * (k / panels)
            half = 0.5 * width / panels
            mid = a0 + half
            for x, w in zip(xs, ws):
                phi = mid + half * float(x)
                r = A * dr.cos(2 * phi - beta) - B
                g = dr.power(dr.maximum(r, 0.0), n) * dr.maximum(dr.cos(phi - al), 0.0) * dr.maximum(dr.cos(phi - av), 0.0)
                acc += float(w) * half * g
        l1, r1 = flat(av)
        l2, r2 = flat(al)
        strip = dr.maximum(dr.minimum(r1, r2) - dr.maximum(l1, l2), 0.0)
        rz = 2 * cl * cv - dot(l, v)
        fl = dr.power(dr.maximum(rz, 0.0), n)
        cav, cal = dr.cos(av), dr.cos(al)
        val = (n + 2) / (2 * math.pi) * (acc + fl * strip * cav * cal) / (P * cav * cal)
        return dr.select(dr.isfinite(val), dr.maximum(val, 0.0), 0.0)
