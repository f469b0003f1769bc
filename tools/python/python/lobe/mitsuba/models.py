"""The Dr.Jit twins of lobe's analytic models (Ngan et al. 2005 section 3.1 and the
anisotropic models, docs/models.md), written from the papers' formulas independently of
lobe's Rust code: ``Lobe(desc, T).value(v, l)`` is the specular lobe for unit local
directions above the surface, over the backend ``T`` (backend.py) so that the same code
runs vectorized in the JIT variants and on one-element arrays in ``scalar_rgb``.
"""

import json
import math

import drjit as dr
import numpy as np

from .backend import dot, normalize

LAMBDA_UM = (0.645, 0.526, 0.444)


def _rgb(v):
    if isinstance(v, (int, float)):
        return [float(v)] * 3
    return [float(x) for x in v]


def _schlick(f0, c):
    m = dr.clip(1.0 - c, 0.0, 1.0)
    return f0 + (1.0 - f0) * (m * m) * (m * m) * m


def _fresnel_dielectric(eta, c):
    c = dr.clip(c, 0.0, 1.0)
    g2 = eta * eta + c * c - 1.0
    g = dr.sqrt(dr.maximum(g2, 0.0))
    a = (g - c) / (g + c)
    b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    f = 0.5 * a * a * (1.0 + b * b)
    return dr.select(g2 <= 0.0, 1.0, dr.clip(f, 0.0, 1.0))


def _erfc(x):
    return 1.0 - dr.erf(x)


def _gaussian_norm(m):
    t = np.linspace(0.0, min(math.pi / 2, 12 * m), 20001)
    f = np.exp(-(t / m) ** 2) * np.cos(t) * np.sin(t)
    integral = np.sum((f[1:] + f[:-1]) * 0.5 * (t[1] - t[0]))
    return float(1.0 / (2 * math.pi * integral))


class Lobe:
    """One model's lobe: value(v, l) -> Color3f for unit local directions above the surface."""

    def __init__(self, d, T):
        self.d = d
        self.T = T
        self.t = d["type"]
        t = self.t
        if t in ("ward", "ward-duer"):
            self.ax = self.ay = d.get("alpha", 0.1)
        elif t == "ward-anisotropic":
            self.ax, self.ay = d.get("alpha_x", 0.1), d.get("alpha_y", 0.1)
        elif t == "cook-torrance":
            self.m = d.get("m", 0.2)
            self.dist = d.get("distribution", "beckmann")
            self.fres = d.get("fresnel", "schlick")
            self.gnorm = _gaussian_norm(self.m) if self.dist == "gaussian" else 0.0
            self.ncp = max(2.0 / (self.m * self.m) - 2.0, 0.0)
        elif t == "ashikhmin-shirley":
            self.nu = self.nv = d.get("n", 100.0)
        elif t == "ashikhmin-shirley-anisotropic":
            self.nu, self.nv = d.get("nu", 100.0), d.get("nv", 100.0)
        elif t == "sampled-microfacet":
            self.mf = MicrofacetGenerator(d, T)

    def widths(self):
        """Two Beckmann widths for the half-vector proposals."""
        t, d = self.t, self.d
        if t in ("ward", "ward-duer", "ward-anisotropic"):
            a = min(self.ax, self.ay)
            return a, max(max(self.ax, self.ay), 3 * a)
        if t == "blinn-phong":
            a = math.sqrt(2.0 / (d.get("n", 100.0) + 2.0))
            return a, min(1.0, 3 * a)
        if t in ("ashikhmin-shirley", "ashikhmin-shirley-anisotropic"):
            return math.sqrt(2.0 / (max(self.nu, self.nv) + 2.0)), math.sqrt(2.0 / (min(self.nu, self.nv) + 2.0))
        if t == "cook-torrance":
            return self.m, min(1.0, 3 * self.m)
        if t == "lafortune":
            a = math.sqrt(2.0 / (4.0 * d.get("n", 100.0) + 2.0))
            return a, min(1.0, 3 * a)
        if t == "he":
            return LAMBDA_UM[1] / (2 * math.pi * d["tau"]), max(2 * d["sigma0"] / d["tau"], 0.01)
        if t == "poulin-fournier":
            return math.sqrt(2.0 / (d.get("n", 100.0) + 2.0)), 0.5
        if t == "sampled-microfacet":
            return self.mf.widths()
        raise ValueError(f"unknown model {t}")

    def value(self, v, l):
        t, d = self.t, self.d
        cv, cl = v.z, l.z
        hu = v + l
        h = normalize(hu)
        if t in ("ward", "ward-duer", "ward-anisotropic"):
            e = dr.exp(-(hu.x * hu.x / (self.ax * self.ax) + hu.y * hu.y / (self.ay * self.ay)) / (hu.z * hu.z))
            # Ward-Duer's cosines are floored at cos(89 deg), as lobe's (materials/src/analytic/ward_duer.rs).
            floor = 0.0174524064372835
            duer = dr.maximum(cl, floor) * dr.maximum(cv, floor)
            den = 4 * math.pi * self.ax * self.ay * (duer if t == "ward-duer" else dr.sqrt(cl * cv))
            return self.T.gray(e / den)
        if t == "blinn-phong":
            n = d.get("n", 100.0)
            return self.T.gray((n + 2) / (2 * math.pi) * dr.power(dr.maximum(h.z, 0.0), n))
        if t == "cook-torrance":
            ch = h.z
            vh = dot(v, h)
            if self.dist == "beckmann":
                c2 = ch * ch
                D = dr.exp(-(1 - c2) / c2 / (self.m * self.m)) / (math.pi * self.m * self.m * c2 * c2)
            elif self.dist == "gaussian":
                th = dr.acos(dr.clip(ch, -1, 1))
                D = self.gnorm * dr.exp(-(th / self.m) ** 2)
            else:
                D = (self.ncp + 2) / (2 * math.pi) * dr.power(dr.maximum(ch, 0.0), self.ncp)
            G = dr.minimum(1.0, dr.minimum(2 * ch * cv / vh, 2 * ch * cl / vh))
            if self.fres == "none":
                F = 1.0
            elif self.fres == "schlick":
                F = _schlick(d.get("f0", 0.04), dot(l, h))
            else:
                F = _fresnel_dielectric(d.get("eta", 1.5), dot(l, h))
            return self.T.gray(dr.select(ch > 0, D * G * F / (math.pi * cl * cv), 0.0))
        if t == "lafortune":
            cx, cy, cz, n = d.get("cx", -0.577), d.get("cy", -0.577), d.get("cz", 0.577), d.get("n", 100.0)
            s = cx * l.x * v.x + cy * l.y * v.y + cz * l.z * v.z
            if d.get("normalization", "ngan") == "ngan":
                cmax = max(abs(cx), abs(cy), abs(cz))
                return self.T.gray((n + 2) / (2 * math.pi) * dr.power(dr.clip(s / cmax, 0.0, 1.0), n))
            return self.T.gray(dr.power(dr.maximum(s, 0.0), n))
        if t in ("ashikhmin-shirley", "ashikhmin-shirley-anisotropic"):
            s2 = h.x * h.x + h.y * h.y
            e = dr.select(s2 > 1e-12, (self.nu * h.x * h.x + self.nv * h.y * h.y) / s2, self.nu)
            lh = dot(l, h)
            val = math.sqrt((self.nu + 1) * (self.nv + 1)) / (8 * math.pi) * dr.power(h.z, e) * _schlick(d.get("f0", 0.05), lh) / (lh * dr.maximum(cl, cv))
            return self.T.gray(dr.select(lh > 0, val, 0.0))
        if t == "he":
            return self._he(v, l, cv, cl, h, hu)
        if t == "poulin-fournier":
            return self.T.gray(self._pf(v, l, cv, cl))
        if t == "sampled-microfacet":
            return self.T.gray(self.mf.value(v, l, h))
        raise ValueError(f"unknown model {t}")

    # He, Torrance, Sillion, Greenberg 1991, directional-diffuse term (Westin's form).
    def _he(self, v, l, cv, cl, h, hu):
        s0, tau, eta = self.d["sigma0"], self.d["tau"], self.d["eta"]
        cd = dot(l, h)
        ch = h.z
        F = _fresnel_dielectric(eta, cd)

        def shadow(c):
            sn = dr.sqrt(dr.maximum(1 - c * c, 1e-14))
            s = tau * (c / sn) / (2 * s0)
            s = dr.minimum(s, 30.0)
            e = _erfc(s)
            lam = dr.exp(-s * s) / (2 * math.sqrt(math.pi) * s) - 0.5 * e
            return dr.select(sn < 1e-7, 1.0, dr.clip((1 - 0.5 * e) / (1 + lam), 0.0, 1.0))

        def kterm(c):
            tn = dr.sqrt(dr.maximum(1 - c * c, 0.0)) / c
            return dr.select(tn > 1e-7, tn * _erfc(tau / (2 * s0 * dr.maximum(tn, 1e-7))), 0.0)

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

    # Poulin-Fournier 1990 cylinders (lobe's reconstruction, docs/models.md).
    def _pf(self, v, l, cv, cl):
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
        F = _schlick(self.f0, dot(l, h))
        val = self._p(h) * F / (4.0 * self._g(v) * self._g(l))
        return dr.select(dr.isfinite(val), dr.maximum(val, 0.0), 0.0)
