"""The array types the model twins compute with: Mitsuba's own in the JIT variants
(``llvm_ad_rgb``, ``cuda_ad_rgb``: one kernel over all lanes), and one-element Dr.Jit
dynamic arrays (``drjit.scalar.ArrayXf``) in the scalar variants, where ``mi.Float`` is a
Python float: plain floats raise on 1/0 and cannot hold a lookup table, the model code
relies on IEEE arithmetic and ``dr.select`` of evaluated branches, so it runs there on
arrays of one lane, whose arithmetic is IEEE as in the vectorized variants."""

import drjit as dr
import drjit.scalar as ds


def dot(a, b):
    return a.x * b.x + a.y * b.y + a.z * b.z


def normalize(a):
    return a * dr.rsqrt(dot(a, a))


class V3:
    """A 3-vector (or RGB colour) of one-lane arrays, with the operations the models use."""

    __slots__ = ("x", "y", "z")

    def __init__(self, x, y, z):
        self.x, self.y, self.z = x, y, z

    @staticmethod
    def _parts(o):
        return (o.x, o.y, o.z) if isinstance(o, V3) else (o, o, o)

    def _op(self, o, f):
        a, b, c = V3._parts(o)
        return V3(f(self.x, a), f(self.y, b), f(self.z, c))

    def __add__(self, o):
        return self._op(o, lambda p, q: p + q)

    __radd__ = __add__

    def __sub__(self, o):
        return self._op(o, lambda p, q: p - q)

    def __rsub__(self, o):
        return self._op(o, lambda p, q: q - p)

    def __mul__(self, o):
        return self._op(o, lambda p, q: p * q)

    __rmul__ = __mul__

    def __truediv__(self, o):
        return self._op(o, lambda p, q: p / q)

    def __neg__(self):
        return V3(-self.x, -self.y, -self.z)


class Jit:
    """Mitsuba's types of a JIT variant."""

    def __init__(self, mi):
        self.mi = mi
        self.Float, self.UInt32 = mi.Float, mi.UInt32

    def Color3f(self, r, g, b):
        return self.mi.Color3f(r, g, b)

    def gray(self, x):
        return self.mi.Color3f(x)

    def color(self, rgb):
        return self.mi.Color3f(*rgb)

    def vec(self, x, y, z):
        return self.mi.Vector3f(x, y, z)

    def table(self, a):
        return self.mi.Float(a)

    def select(self, m, a, b):
        return dr.select(m, a, b)

    # Mitsuba values in and out: nothing to convert.
    def wrap_vec(self, v):
        return v

    def wrap(self, x):
        return x

    def out_color(self, c):
        return c

    def out(self, x):
        return x

    def out_mask(self, m):
        return m


class Scalar:
    """One-lane Dr.Jit dynamic arrays for the scalar variants."""

    Float, UInt32 = ds.ArrayXf, ds.ArrayXu

    def __init__(self, mi):
        self.mi = mi

    def Color3f(self, r, g, b):
        return V3(r, g, b)

    def gray(self, x):
        return V3(x, x, x)

    def color(self, rgb):
        return V3(*(ds.ArrayXf(float(c)) for c in rgb))

    def vec(self, x, y, z):
        return V3(x, y, z)

    def table(self, a):
        return ds.ArrayXf(a)

    def select(self, m, a, b):
        if isinstance(a, V3) or isinstance(b, V3):
            (ax, ay, az), (bx, by, bz) = V3._parts(a), V3._parts(b)
            return V3(dr.select(m, ax, bx), dr.select(m, ay, by), dr.select(m, az, bz))
        return dr.select(m, a, b)

    def wrap_vec(self, v):
        return V3(ds.ArrayXf(float(v[0])), ds.ArrayXf(float(v[1])), ds.ArrayXf(float(v[2])))

    def wrap(self, x):
        return ds.ArrayXf(float(x))

    def out_color(self, c):
        return self.mi.Color3f(float(c.x[0]), float(c.y[0]), float(c.z[0]))

    def out(self, x):
        return float(x[0])

    def out_mask(self, m):
        return bool(m[0])


def for_variant(mi):
    """The backend of Mitsuba's current variant."""
    return Scalar(mi) if mi.variant().startswith("scalar") else Jit(mi)
