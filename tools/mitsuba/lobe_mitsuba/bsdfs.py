"""Mitsuba 3 BSDF plugins for the analytic models of Ngan et al. 2005, written from the
papers' formulas as lobe documents them (docs/models.md), in Dr.Jit so that they run
vectorized in llvm_ad_rgb: `lobe_analytic` takes the model description as a JSON string
(`desc`) and evaluates diffuse/pi + specular * lobe.

Sampling is deliberately simple and independent of lobe's: a mixture of cosine sampling
and two Beckmann half-vector proposals whose widths come from the model's parameters; it
is unbiased for every model (cosine sampling covers the whole hemisphere) and efficient
enough for reference renders.
"""

import json
import math

import drjit as dr
import mitsuba as mi
import numpy as np

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

    def __init__(self, d):
        self.d = d
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
        raise ValueError(f"unknown model {t}")

    def value(self, v, l):
        t, d = self.t, self.d
        cv, cl = mi.Frame3f.cos_theta(v), mi.Frame3f.cos_theta(l)
        hu = v + l
        h = dr.normalize(hu)
        if t in ("ward", "ward-duer", "ward-anisotropic"):
            e = dr.exp(-(hu.x * hu.x / (self.ax * self.ax) + hu.y * hu.y / (self.ay * self.ay)) / (hu.z * hu.z))
            den = 4 * math.pi * self.ax * self.ay * (cl * cv if t == "ward-duer" else dr.sqrt(cl * cv))
            return mi.Color3f(e / den)
        if t == "blinn-phong":
            n = d.get("n", 100.0)
            return mi.Color3f((n + 2) / (2 * math.pi) * dr.power(dr.maximum(h.z, 0.0), n))
        if t == "cook-torrance":
            ch = h.z
            vh = dr.dot(v, h)
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
                F = _schlick(d.get("f0", 0.04), dr.dot(l, h))
            else:
                F = _fresnel_dielectric(d.get("eta", 1.5), dr.dot(l, h))
            return mi.Color3f(dr.select(ch > 0, D * G * F / (math.pi * cl * cv), 0.0))
        if t == "lafortune":
            cx, cy, cz, n = d.get("cx", -0.577), d.get("cy", -0.577), d.get("cz", 0.577), d.get("n", 100.0)
            s = cx * l.x * v.x + cy * l.y * v.y + cz * l.z * v.z
            if d.get("normalization", "ngan") == "ngan":
                cmax = max(abs(cx), abs(cy), abs(cz))
                return mi.Color3f((n + 2) / (2 * math.pi) * dr.power(dr.clip(s / cmax, 0.0, 1.0), n))
            return mi.Color3f(dr.power(dr.maximum(s, 0.0), n))
        if t in ("ashikhmin-shirley", "ashikhmin-shirley-anisotropic"):
            s2 = h.x * h.x + h.y * h.y
            e = dr.select(s2 > 1e-12, (self.nu * h.x * h.x + self.nv * h.y * h.y) / s2, self.nu)
            lh = dr.dot(l, h)
            val = math.sqrt((self.nu + 1) * (self.nv + 1)) / (8 * math.pi) * dr.power(h.z, e) * _schlick(d.get("f0", 0.05), lh) / (lh * dr.maximum(cl, cv))
            return mi.Color3f(dr.select(lh > 0, val, 0.0))
        if t == "he":
            return self._he(v, l, cv, cl, h, hu)
        if t == "poulin-fournier":
            return mi.Color3f(self._pf(v, l, cv, cl))
        raise ValueError(f"unknown model {t}")

    # He, Torrance, Sillion, Greenberg 1991, directional-diffuse term (Westin's form).
    def _he(self, v, l, cv, cl, h, hu):
        s0, tau, eta = self.d["sigma0"], self.d["tau"], self.d["eta"]
        cd = dr.dot(l, h)
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
            series = dr.zeros(mi.Float)
            gm = dr.ones(mi.Float)
            for m in range(1, 65):
                gm = gm * g / m
                series += dr.exp(-g - E / m) * gm / m
            rough = dr.exp(-E / dr.maximum(g, 1e-30)) / dr.maximum(g, 1e-30)
            w = dr.clip(gmin - 18.0, 0.0, 1.0)
            total = dr.select(gmin > 19.0, rough, (1 - w) * series + w * rough)
            val = F * S * G * N * total / (math.pi * cl * cv)
            out.append(dr.select(dr.isfinite(val) & (cd > 0), dr.maximum(val, 0.0), 0.0))
        return mi.Color3f(out[0], out[1], out[2])

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
        acc = dr.zeros(mi.Float)
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
        rz = 2 * cl * cv - dr.dot(l, v)
        fl = dr.power(dr.maximum(rz, 0.0), n)
        cav, cal = dr.cos(av), dr.cos(al)
        val = (n + 2) / (2 * math.pi) * (acc + fl * strip * cav * cal) / (P * cav * cal)
        return dr.select(dr.isfinite(val), dr.maximum(val, 0.0), 0.0)


def _beckmann_sample(alpha, u):
    phi = 2 * math.pi * u.x
    tan2 = -alpha * alpha * dr.log(dr.maximum(1.0 - u.y, 1e-30))
    c = dr.rsqrt(1 + tan2)
    s = dr.sqrt(dr.maximum(1 - c * c, 0.0))
    return mi.Vector3f(s * dr.cos(phi), s * dr.sin(phi), c)


def _beckmann_pdf_h(alpha, h):
    c2 = h.z * h.z
    d = dr.exp(-(1 - c2) / c2 / (alpha * alpha)) / (math.pi * alpha * alpha * c2 * h.z)
    return dr.select(h.z > 0, d, 0.0)


class LobeAnalytic(mi.BSDF):
    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        d = json.loads(props["desc"])
        self.diffuse = mi.Color3f(_rgb(d.get("diffuse", 0.0)))
        self.specular = mi.Color3f(_rgb(d.get("specular", 0.04)))
        self.lobe = Lobe(d)
        self.a1, self.a2 = self.lobe.widths()
        lum = lambda c: 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
        self.p_cos = 0.5 if lum(_rgb(d.get("diffuse", 0.0))) > 0 else 0.2
        flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
        if d["type"].endswith("anisotropic") or d["type"] == "poulin-fournier":
            flags = flags | mi.BSDFFlags.Anisotropic
        self.m_flags = flags
        self.m_components = [flags]

    def _f(self, v, l):
        ok = (mi.Frame3f.cos_theta(v) > 0) & (mi.Frame3f.cos_theta(l) > 0)
        f = self.diffuse / math.pi + self.specular * self.lobe.value(v, l)
        return dr.select(ok, f, 0.0)

    def _pdf(self, v, l):
        h = dr.normalize(v + l)
        vh = dr.dot(v, h)
        jac = dr.select(vh > 0, 1.0 / (4 * vh), 0.0)
        p_half = 0.5 * (_beckmann_pdf_h(self.a1, h) + _beckmann_pdf_h(self.a2, h)) * jac
        p = self.p_cos * dr.maximum(mi.Frame3f.cos_theta(l), 0.0) / math.pi + (1 - self.p_cos) * p_half
        ok = (mi.Frame3f.cos_theta(v) > 0) & (mi.Frame3f.cos_theta(l) > 0)
        return dr.select(ok, p, 0.0)

    def sample(self, ctx, si, sample1, sample2, active=True):
        v = si.wi
        use_cos = sample1 < self.p_cos
        u_rest = dr.select(use_cos, 0.0, (sample1 - self.p_cos) / (1 - self.p_cos))
        wcos = mi.warp.square_to_cosine_hemisphere(sample2)
        h = dr.select(u_rest < 0.5, _beckmann_sample(self.a1, sample2), _beckmann_sample(self.a2, sample2))
        wref = 2 * dr.dot(v, h) * h - v
        l = dr.select(use_cos, wcos, wref)
        pdf = self._pdf(v, l)
        bs = dr.zeros(mi.BSDFSample3f)
        bs.wo = l
        bs.pdf = pdf
        bs.eta = 1.0
        bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
        bs.sampled_component = mi.UInt32(0)
        ok = active & (pdf > 0) & (mi.Frame3f.cos_theta(v) > 0) & (mi.Frame3f.cos_theta(l) > 0)
        val = self._f(v, l) * mi.Frame3f.cos_theta(l) / dr.maximum(pdf, 1e-30)
        return (bs, dr.select(ok, val, 0.0))

    def eval(self, ctx, si, wo, active=True):
        return dr.select(active, self._f(si.wi, wo) * dr.maximum(mi.Frame3f.cos_theta(wo), 0.0), 0.0)

    def pdf(self, ctx, si, wo, active=True):
        return dr.select(active, self._pdf(si.wi, wo), 0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

    def traverse(self, callback):
        pass

    def parameters_changed(self, keys):
        pass

    def to_string(self):
        return f"LobeAnalytic[{self.lobe.t}]"


def register():
    mi.register_bsdf("lobe_analytic", lambda props: LobeAnalytic(props))
