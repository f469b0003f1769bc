"""The sampled-microfacet generator (Ashikhmin, Premoze and Shirley 2000) as a Dr.Jit twin
(materials/src/microfacet_gen/ in lobe)."""

import math

import drjit as dr
import numpy as np

from ..backend import dot, normalize
from .common import schlick


class SampledMicrofacet:
    TYPES = ("sampled-microfacet",)

    def __init__(self, d, T):
        self.T, self.mf = T, MicrofacetGenerator(d, T)

    def widths(self):
        return self.mf.widths()

    def value(self, v, l):
        return self.T.gray(self.mf.value(v, l, normalize(v + l)))


class MicrofacetGenerator:
    """Ashikhmin, Premoze, Shirley 2000: rho = p(h) <h.n> F(k.h) / (4 g(k1) g(k2)) with
    g(k) = int (h.k)+ p(h) dw. Written from the paper independently of lobe's table: p is
    evaluated in closed form (the structures of docs/microfacet.md), <h.n> and g(k) by
    midpoint quadrature over a (theta_h, phi_h) grid, g tabulated on (theta_k, phi_k)
    nodes every 1 and 2.5 degrees and interpolated bilinearly."""

    GT, GP = 91, 145  # theta_k 0..90 by 1 degree, phi_k 0..360 by 2.5 degrees
    # Midpoint quadrature cells over (theta_h, phi_h) for <h.n> and g(k); tests set a
    # coarser grid to build the twin in a second.
    QUADRATURE = (360, 720)

    def __init__(self, d, T):
        self.T = T
        dist = d.get("distribution", "beckmann")
        self.f0 = float(d.get("f0", 1.0))
        rad = math.radians
        if dist == "beckmann":
            self.kind, self.par = "beckmann", (float(d.get("alpha_x", 0.2)), float(d.get("alpha_y", 0.2)))
        elif dist == "brushed":
            self.kind, self.par = "ridges", ([(1.0, 0.0, 0.0)], rad(3.0), rad(35.0))
        elif dist == "satin":
            t = rad(25.0)
            self.kind, self.par = "ridges", ([(math.cos(t), 0.0, math.sin(t)), (math.cos(t), 0.0, -math.sin(t))], rad(5.0), rad(45.0))
        elif dist == "velvet":
            self.kind, self.par = "velvet", (rad(12.0), rad(62.0), rad(8.0), 0.25)
        else:
            raise ValueError(f"sampled-microfacet: distribution {dist!r} (tables from files are not supported here)")
        # Quadrature grid over the hemisphere of h.
        nt, npp = self.QUADRATURE
        th = (np.arange(nt) + 0.5) * (math.pi / 2) / nt
        ph = (np.arange(npp) + 0.5) * 2 * math.pi / npp
        TH, PH = np.meshgrid(th, ph, indexing="ij")
        H = np.stack([np.sin(TH) * np.cos(PH), np.sin(TH) * np.sin(PH), np.cos(TH)], -1).reshape(-1, 3)
        w = (np.sin(TH) * (math.pi / 2 / nt) * (2 * math.pi / npp)).reshape(-1)
        pw = self._p_np(H) * w
        self.norm = 1.0 / float(np.sum(pw * H[:, 2]))  # <h.n> = 1 after scaling p
        pw *= self.norm
        tk = np.radians(np.minimum(np.arange(self.GT) * 1.0, 89.95))
        pk = np.radians(np.arange(self.GP) * 2.5)
        TK, PK = np.meshgrid(tk, pk, indexing="ij")
        K = np.stack([np.sin(TK) * np.cos(PK), np.sin(TK) * np.sin(PK), np.cos(TK)], -1).reshape(-1, 3)
        g = np.empty(len(K))
        for i in range(0, len(K), 256):
            g[i:i + 256] = np.maximum(K[i:i + 256] @ H.T, 0.0) @ pw
        self.g = self.T.table(np.maximum(g, 1e-6).astype(np.float32))

    def _p_np(self, H):
        x, y, z = H[:, 0], H[:, 1], H[:, 2]
        th = np.arccos(np.clip(z, -1, 1))
        if self.kind == "beckmann":
            ax, ay = self.par
            return np.exp(-(x * x / ax**2 + y * y / ay**2) / (z * z)) / (math.pi * ax * ay * z**4)
        if self.kind == "ridges":
            axes, wid, fall = self.par
            r = sum(np.exp(-(np.arcsin(np.clip(H @ np.array(a), -1, 1)) / wid) ** 2) for a in axes)
            return r * np.exp(-(th / fall) ** 2)
        m, ring, rw, wt = self.par
        return np.exp(-(th / m) ** 2) + wt * np.exp(-((th - ring) / rw) ** 2)

    def _p(self, h):
        th = dr.acos(dr.clip(h.z, -1.0, 1.0))
        if self.kind == "beckmann":
            ax, ay = self.par
            z2 = h.z * h.z
            v = dr.exp(-(h.x * h.x / ax**2 + h.y * h.y / ay**2) / z2) / (math.pi * ax * ay * z2 * z2)
        elif self.kind == "ridges":
            axes, wid, fall = self.par
            r = self.T.Float(0.0)
            for a in axes:
                off = dr.asin(dr.clip(h.x * a[0] + h.y * a[1] + h.z * a[2], -1.0, 1.0))
                r += dr.exp(-(off / wid) ** 2)
            v = r * dr.exp(-(th / fall) ** 2)
        else:
            m, ring, rw, wt = self.par
            v = dr.exp(-(th / m) ** 2) + wt * dr.exp(-((th - ring) / rw) ** 2)
        return dr.select(h.z > 0, v * self.norm, 0.0)

    def _g(self, k):
        t = dr.acos(dr.clip(k.z, -1.0, 1.0)) * (180.0 / math.pi)
        p = dr.atan2(k.y, k.x) * (180.0 / math.pi)
        p = dr.select(p < 0, p + 360.0, p) / 2.5
        t = dr.minimum(t, 89.95)
        it = dr.minimum(self.T.UInt32(dr.floor(t)), self.GT - 2)
        ip = dr.minimum(self.T.UInt32(dr.floor(p)), self.GP - 2)
        ft, fp = t - self.T.Float(it), p - self.T.Float(ip)
        at = lambda a, b: dr.gather(self.T.Float, self.g, a * self.GP + b)
        return (1 - ft) * ((1 - fp) * at(it, ip) + fp * at(it, ip + 1)) + ft * ((1 - fp) * at(it + 1, ip) + fp * at(it + 1, ip + 1))

    def widths(self):
        if self.kind == "beckmann":
            return min(self.par), max(self.par)
        return 0.1, 0.5

    def value(self, v, l, h):
        F = schlick(self.f0, dot(l, h))
        val = self._p(h) * F / (4.0 * self._g(v) * self._g(l))
        return dr.select(dr.isfinite(val), dr.maximum(val, 0.0), 0.0)
