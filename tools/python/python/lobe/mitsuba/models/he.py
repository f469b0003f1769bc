"""He, Torrance, Sillion and Greenberg 1991's directional-diffuse term (Westin's form of
the series, as Ngan et al. 2005 use it; materials/src/analytic/he.rs)."""

import math

import drjit as dr

from ..backend import dot, normalize
from .common import LAMBDA_UM, erfc, fresnel_dielectric


class He:
    TYPES = ("he",)

    def __init__(self, d, T):
        self.T, self.d = T, d

    def widths(self):
        d = self.d
        return LAMBDA_UM[1] / (2 * math.pi * d["tau"]), max(2 * d["sigma0"] / d["tau"], 0.01)

    def value(self, v, l):
        cv, cl = v.z, l.z
        hu = v + l
        h = normalize(hu)
        s0, tau, eta = self.d["sigma0"], self.d["tau"], self.d["eta"]
        cd = dot(l, h)
        ch = h.z
        F = fresnel_dielectric(eta, cd)

        def shadow(c):
            sn = dr.sqrt(dr.maximum(1 - c * c, 1e-14))
            s = tau * (c / sn) / (2 * s0)
            s = dr.minimum(s, 30.0)
            e = erfc(s)
            lam = dr.exp(-s * s) / (2 * math.sqrt(math.pi) * s) - 0.5 * e
            return dr.select(sn < 1e-7, 1.0, dr.clip((1 - 0.5 * e) / (1 + lam), 0.0, 1.0))

        def kterm(c):
            tn = dr.sqrt(dr.maximum(1 - c * c, 0.0)) / c
            return dr.select(tn > 1e-7, tn * erfc(tau / (2 * s0 * dr.maximum(tn, 1e-7))), 0.0)

        S = shadow(cl) * shadow(cv)
        G = 4 * cd * cd / (ch * ch)
        f0 = (kterm(cl) + kterm(cv)) / math.sqrt(8 * math.pi)
        x = dr.select(f0 <= 1, f0, dr.sqrt(2 * dr.log(dr.maximum(f0, 1.0))))
        for _ in range(4):
            ex = dr.exp(0.5 * x * x)
            x = x - (x * ex - f0) / ((1 + x * x) * ex)
        sigma = s0 / dr.sqrt(1 + x * x)
        vxy2 = hu.x * hu.x + hu.y * hu.y
        gs = [(2 * math.pi * sigma * (cl + cv) / lam_c) ** 2 for lam_c in LAMBDA_UM]
        gmin = dr.minimum(gs[0], dr.minimum(gs[1], gs[2]))
        out = []
        for g, lam_c in zip(gs, LAMBDA_UM):
            N = math.pi ** 2 * tau * tau / (4 * lam_c * lam_c)
            E = math.pi ** 2 * tau * tau * vxy2 / (lam_c * lam_c)
            series = self.T.Float(0.0)
            gm = self.T.Float(1.0)
            for m in range(1, 65):
                gm = gm * g / m
                series += dr.exp(-g - E / m) * gm / m
            rough = dr.exp(-E / dr.maximum(g, 1e-30)) / dr.maximum(g, 1e-30)
            w = dr.clip(gmin - 18.0, 0.0, 1.0)
            total = dr.select(gmin > 19.0, rough, (1 - w) * series + w * rough)
            val = F * S * G * N * total / (math.pi * cl * cv)
            out.append(dr.select(dr.isfinite(val) & (cd > 0), dr.maximum(val, 0.0), 0.0))
        return self.T.Color3f(out[0], out[1], out[2])
