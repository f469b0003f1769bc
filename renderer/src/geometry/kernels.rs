//! Ray-primitive intersection in SIMD lanes, one kernel per primitive kind, each with the
//! operations of the scalar test ([`Triangle::intersect`], [`Sphere::intersect`],
//! [`Rectangle::intersect`]) in the same order (for triangles, the same function:
//! [`moller_trumbore`]), so a lane's distance is bit for bit the scalar one. The kernels
//! are generic over the vector ([`Arith`]), so one kernel serves both batch shapes the
//! renderer uses: one ray against the eight primitives of a BVH8 leaf block
//! (`wide::f32x8`, the ray splatted) and many rays against one primitive (the primitive
//! splatted: eight coherent rays of a BVH8 packet, `wide::f32x8`, and [`LANES`] rays in
//! small scenes tested exhaustively, `f32xn`).

#[cfg(doc)]
use super::{Rectangle, Sphere, Triangle};
pub use lobe_materials::math::V3;
use lobe_materials::math::{Arith, abs, all, eq, ge, gt, le, lt, select, sqrt};
#[cfg(doc)]
use lobe_materials::simd::LANES;

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
pub fn splat3<F: Arith>(v: glam::Vec3) -> V3<F> {
    V3::new(F::of(v.x as f64), F::of(v.y as f64), F::of(v.z as f64))
}

const INF: f64 = f64::INFINITY;

/// Möller-Trumbore's quantities for a ray and a triangle: the determinant, the
/// barycentrics (u, v) of the ray's line in the triangle's plane and the distance along it.
#[derive(Clone, Copy)]
pub struct MollerTrumbore<F> {
    pub det: F,
    pub u: F,
    pub v: F,
    pub t: F,
}

/// Möller-Trumbore's computation for rays from `o` along `d` and triangles (vertex `p0`,
/// edges `e1`, `e2`), one or lanes of them: the one the scalar test
/// ([`Triangle::intersect_bary`]), the leaf kernel ([`triangle`]) and the hits' local
/// geometry share.
#[inline(always)]
pub fn moller_trumbore<F: Arith>(
    o: V3<F>,
    d: V3<F>,
    p0: V3<F>,
    e1: V3<F>,
    e2: V3<F>,
) -> MollerTrumbore<F> {
    let pvec = d.cross(e2);
    let det = e1.dot(pvec);
    let inv_det = F::of(1.0) / det;
    let tvec = o - p0;
    let u = tvec.dot(pvec) * inv_det;
    let qvec = tvec.cross(e1);
    let v = d.dot(qvec) * inv_det;
    let t = e2.dot(qvec) * inv_det;
    MollerTrumbore { det, u, v, t }
}

/// Where [`moller_trumbore`]'s quantities `q` are a hit in (`tmin`, `tmax`), NaN cases
/// included: det nonzero and finite, u in [0, 1], not v < 0, not u + v > 1, t in (tmin,
/// tmax).
#[inline(always)]
pub fn triangle_hit<F: Arith>(q: MollerTrumbore<F>, tmin: F, tmax: F) -> F::Mask {
    let (zero, one) = (F::of(0.0), F::of(1.0));
    !eq(q.det, zero)
        & lt(abs(q.det), F::of(INF))
        & ge(q.u, zero)
        & le(q.u, one)
        & !lt(q.v, zero)
        & !gt(q.u + q.v, one)
        & gt(q.t, tmin)
        & lt(q.t, tmax)
}

/// Möller-Trumbore ([`Triangle::intersect`]) of triangles (vertex `p0`, edges `e1`, `e2`):
/// the distance in (tmin, tmax), else infinity.
#[inline(always)]
pub fn triangle<F: Arith>(r: &RayLanes<F>, p0: V3<F>, e1: V3<F>, e2: V3<F>) -> F {
    let q = moller_trumbore(r.o, r.d, p0, e1, e2);
    select(triangle_hit(q, r.tmin, r.tmax), q.t, F::of(INF))
}

/// Spheres ([`Sphere::intersect`]: Haines et al.'s careful quadratic) of centres `c` and
/// radii `radius`.
#[inline(always)]
pub fn sphere<F: Arith>(r: &RayLanes<F>, c: V3<F>, radius: F) -> F {
    let (zero, one, inf) = (F::of(0.0), F::of(1.0), F::of(INF));
    let d = r.d;
    let r2 = radius * radius;
    let d_len2 = d.dot(d);
    let inv_len2 = one / d_len2;
    let f = r.o - c;
    let b = -f.dot(d);
    let s = b * inv_len2;
    let l = f + d * s;
    let disc = (r2 - l.dot(l)) * d_len2;
    // Rays of a batch often all miss a sphere (the coherent camera rays of a wavefront,
    // a scene's far spheres): then the square root and divisions are skipped, as the
    // scalar test returns early. The answer is the same (every lane infinite).
    if all::<F>(lt(disc, zero)) {
        return inf;
    }
    let cc = f.dot(f) - r2;
    let sq = sqrt(disc);
    let q = select(ge(b, zero), b + sq, b - sq);
    let (a0, a1) = (cc / q, q * inv_len2);
    let swap = gt(a0, a1);
    let (t0, t1) = (select(swap, a1, a0), select(swap, a0, a1));
    let t = select(
        gt(t0, r.tmin) & lt(t0, r.tmax),
        t0,
        select(gt(t1, r.tmin) & lt(t1, r.tmax), t1, inf),
    );
    select(lt(disc, zero), inf, t)
}

/// Rectangles ([`Rectangle::intersect`]) of corner `corner`, unit normal `n` and dual
/// edge vectors `du`, `dv`.
#[inline(always)]
pub fn rectangle<F: Arith>(r: &RayLanes<F>, corner: V3<F>, n: V3<F>, du: V3<F>, dv: V3<F>) -> F {
    let (zero, one) = (F::of(0.0), F::of(1.0));
    let denom = r.d.dot(n);
    let t = (corner - r.o).dot(n) / denom;
    // ray.at(t) - corner: o + d t - corner.
    let rel = (r.o + r.d * t) - corner;
    let u = rel.dot(du);
    let v = rel.dot(dv);
    let ok = !eq(denom, zero)
        & gt(t, r.tmin)
        & lt(t, r.tmax)
        & ge(u, zero)
        & le(u, one)
        & ge(v, zero)
        & le(v, one);
    select(ok, t, F::of(INF))
}
