//! Ray-primitive intersection in SIMD lanes, one kernel per primitive kind, each with the
//! operations of the scalar test ([`Triangle::intersect`], [`Sphere::intersect`],
//! [`Rectangle::intersect`]) in the same order, so a lane's distance is bit for bit the
//! scalar one. The kernels are generic over the vector ([`FloatLanes`]), so one kernel
//! serves both batch shapes the renderer uses: one ray against the eight primitives of a
//! BVH8 leaf block (`wide::f32x8`, the ray splatted) and [`LANES`] rays against one
//! primitive (small scenes tested exhaustively, `f32xn`, the primitive splatted).

#[cfg(doc)]
use super::{Rectangle, Sphere, Triangle};
#[cfg(doc)]
use lobe_materials::simd::LANES;
use lobe_materials::simd::{FloatLanes, dot3 as dot, sel};

/// Lanes of a 3-vector, one array per axis.
pub type V3<F> = [F; 3];

/// Rays in lanes: origins, directions and the open range (tmin, tmax).
#[derive(Clone, Copy)]
pub struct RayLanes<F> {
    pub o: V3<F>,
    pub d: V3<F>,
    pub tmin: F,
    pub tmax: F,
}

/// Every lane of `v`.
#[inline(always)]
pub fn splat3<F: FloatLanes>(v: glam::Vec3) -> V3<F> {
    [F::splat(v.x), F::splat(v.y), F::splat(v.z)]
}

#[inline(always)]
fn cross<F: FloatLanes>(a: V3<F>, b: V3<F>) -> V3<F> {
    // glam's order.
    [
        a[1] * b[2] - b[1] * a[2],
        a[2] * b[0] - b[2] * a[0],
        a[0] * b[1] - b[0] * a[1],
    ]
}

#[inline(always)]
fn sub<F: FloatLanes>(a: V3<F>, b: V3<F>) -> V3<F> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

const INF: f32 = f32::INFINITY;

/// Möller-Trumbore ([`Triangle::intersect`]) of triangles (vertex `p0`, edges `e1`, `e2`):
/// the distance in (tmin, tmax), else infinity.
#[inline(always)]
pub fn triangle<F: FloatLanes>(r: &RayLanes<F>, p0: V3<F>, e1: V3<F>, e2: V3<F>) -> F {
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    let pvec = cross(r.d, e2);
    let det = dot(e1, pvec);
    let inv_det = one / det;
    let tvec = sub(r.o, p0);
    let u = dot(tvec, pvec) * inv_det;
    let qvec = cross(tvec, e1);
    let v = dot(r.d, qvec) * inv_det;
    let t = dot(e2, qvec) * inv_det;
    // The scalar test's conditions, NaN cases included: det nonzero and finite, u in
    // [0, 1], not v < 0, not u + v > 1, t in (tmin, tmax).
    let ok = !det.simd_eq(zero)
        & det.abs().simd_lt(F::splat(INF))
        & u.simd_ge(zero)
        & u.simd_le(one)
        & !v.simd_lt(zero)
        & !(u + v).simd_gt(one)
        & t.simd_gt(r.tmin)
        & t.simd_lt(r.tmax);
    sel(ok, t, F::splat(INF))
}

/// Spheres ([`Sphere::intersect`]: Haines et al.'s careful quadratic) of centres `c` and
/// radii `radius`.
#[inline(always)]
pub fn sphere<F: FloatLanes>(r: &RayLanes<F>, c: V3<F>, radius: F) -> F {
    let (zero, one, inf) = (F::splat(0.0), F::splat(1.0), F::splat(INF));
    let d = r.d;
    let r2 = radius * radius;
    let d_len2 = dot(d, d);
    let inv_len2 = one / d_len2;
    let f = sub(r.o, c);
    let b = -dot(f, d);
    let s = b * inv_len2;
    let l = [f[0] + d[0] * s, f[1] + d[1] * s, f[2] + d[2] * s];
    let disc = (r2 - dot(l, l)) * d_len2;
    // Rays of a batch often all miss a sphere (the coherent camera rays of a wavefront,
    // a scene's far spheres): then the square root and divisions are skipped, as the
    // scalar test returns early. The answer is the same (every lane infinite).
    if disc.simd_lt(zero).all() {
        return inf;
    }
    let cc = dot(f, f) - r2;
    let sq = disc.sqrt();
    let q = sel(b.simd_ge(zero), b + sq, b - sq);
    let (a0, a1) = (cc / q, q * inv_len2);
    let swap = a0.simd_gt(a1);
    let (t0, t1) = (sel(swap, a1, a0), sel(swap, a0, a1));
    let t = sel(
        t0.simd_gt(r.tmin) & t0.simd_lt(r.tmax),
        t0,
        sel(t1.simd_gt(r.tmin) & t1.simd_lt(r.tmax), t1, inf),
    );
    sel(disc.simd_lt(zero), inf, t)
}

/// Rectangles ([`Rectangle::intersect`]) of corner `corner`, unit normal `n` and dual
/// edge vectors `du`, `dv`.
#[inline(always)]
pub fn rectangle<F: FloatLanes>(
    r: &RayLanes<F>,
    corner: V3<F>,
    n: V3<F>,
    du: V3<F>,
    dv: V3<F>,
) -> F {
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    let denom = dot(r.d, n);
    let t = dot(sub(corner, r.o), n) / denom;
    // ray.at(t) - corner: o + d t - corner.
    let at = [
        r.o[0] + r.d[0] * t,
        r.o[1] + r.d[1] * t,
        r.o[2] + r.d[2] * t,
    ];
    let rel = sub(at, corner);
    let u = dot(rel, du);
    let v = dot(rel, dv);
    let ok = !denom.simd_eq(zero)
        & t.simd_gt(r.tmin)
        & t.simd_lt(r.tmax)
        & u.simd_ge(zero)
        & u.simd_le(one)
        & v.simd_ge(zero)
        & v.simd_le(one);
    sel(ok, t, F::splat(INF))
}
