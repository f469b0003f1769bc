//! The tabulated distribution of normals p(h) of the Ashikhmin-Premože-Shirley generator
//! (SIGGRAPH 2000): node values over the projected hemisphere, normalized so that
//! <h.n> = 1, interpolated bilinearly; APS2000's shadowing term g(k) = int (h.k)+ p(h) dw
//! tabulated on (theta_k, phi_k) nodes by quadrature over the same grid; the sampler of
//! the normals visible from wo ([`VisibleSampler`]); the forward model
//! rho (Ngan et al. 2005, section 5, Eq. 3); and the EXR file a table is stored in.
//!
//! Each lookup is written once over [`Num`]: f64 for fitting, f32 and lanes for rendering
//! ([`crate::fastmath`]'s acos and atan2, gathers from the f32 tables).

use super::visible::VisibleSampler;
use crate::math::{
    Num, V3, acos, atan2, gt, is_finite, le, lt, maximum, minimum, select, to_degrees,
};
use crate::simd::{MaskN, Vec3xN, f32xn};
use glam::DVec3;
use std::path::Path;

/// Default nodes per side of the distribution table.
pub const DEFAULT_RES: usize = 257;
/// Nodes of the g(k) table: theta_k every 2 degrees, phi_k every 5 degrees.
const G_THETA: usize = 46;
const G_PHI: usize = 73;

/// A tabulated distribution of normals with its shadowing table and sampler.
#[derive(Clone, Debug)]
pub struct Table {
    pub(super) n: usize,
    /// Node values of p, normalized: sum p * cell^2 = 1 (so <h.n> = 1).
    pub(super) p: Vec<f32>,
    /// g(k) at (theta, phi) nodes.
    g: Vec<f32>,
    /// The corners of each (theta, phi) cell of `g`, for the lane lookups.
    g_cells: CellCorners,
    /// The sampler of visible normals.
    visible: VisibleSampler,
}

pub(super) fn node_dir(n: usize, i: usize, j: usize) -> Option<DVec3> {
    let s = 2.0 / (n - 1) as f64;
    let (x, y) = (-1.0 + i as f64 * s, -1.0 + j as f64 * s);
    let r2 = x * x + y * y;
    (r2 < 1.0).then(|| DVec3::new(x, y, (1.0 - r2).sqrt()))
}

/// The node below a non-negative table coordinate, at most `last` (NaN gives 0).
#[inline(always)]
pub(super) fn node_index<T: Num>(x: T, last: usize) -> T::Int {
    T::int_min(T::int_max(x.trunc_int(), T::int(0)), T::int(last as i32))
}

/// The four corner values of every cell of a row-major grid of nodes, one 16-byte packet
/// per cell ([v(i, j), v(i + 1, j), v(i, j + 1), v(i + 1, j + 1)]), so that a lane
/// lookup reads one packet per lane and transposes them ([`Num::gather4`]) instead of
/// gathering four values per lane.
#[derive(Clone, Debug)]
struct CellCorners {
    /// Cells per row (nodes per row - 1).
    cells_per_row: usize,
    /// The packets, four values each, one after the other.
    packets: Vec<f32>,
}

impl CellCorners {
    /// From `cols` x `rows` node values, row-major.
    fn new(v: &[f32], cols: usize, rows: usize) -> Self {
        assert!(cols >= 2 && rows >= 2 && v.len() == cols * rows);
        let packets = (0..rows - 1)
            .flat_map(|j| (0..cols - 1).map(move |i| (i, j)))
            .flat_map(|(i, j)| {
                let at = |i: usize, j: usize| v[j * cols + i];
                [at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]
            })
            .collect();
        CellCorners {
            cells_per_row: cols - 1,
            packets,
        }
    }

    fn memory_bytes(&self) -> usize {
        self.packets.len() * std::mem::size_of::<f32>()
    }

    /// The corners of cell (ix, iy) (indices are clamped to the grid).
    #[inline(always)]
    fn corners<T: Num>(&self, ix: T::Int, iy: T::Int) -> [T; 4] {
        let last = T::int(self.packets.len() as i32 / 4 - 1);
        let k = T::int_min(
            T::int_max(iy * T::int(self.cells_per_row as i32) + ix, T::int(0)),
            last,
        );
        T::gather4(&self.packets, k * T::int(4))
    }
}

/// Bilinear interpolation of corners [(0, 0), (1, 0), (0, 1), (1, 1)] at (fx, fy).
#[inline(always)]
fn bilinear<T: Num>(fx: T, fy: T, [a, b, c, d]: [T; 4]) -> T {
    let one = T::of(1.0);
    (one - fy) * ((one - fx) * a + fx * b) + fy * ((one - fx) * c + fx * d)
}

fn g_dir(t: usize, f: usize) -> DVec3 {
    let theta = (t as f64 * 2.0).to_radians().min(89.9f64.to_radians());
    let phi = (f as f64 * 5.0).to_radians();
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

impl Table {
    /// Tabulates `f` (any non-negative density, normalized here) on `n` x `n` nodes.
    pub fn from_fn(n: usize, f: impl Fn(DVec3) -> f64 + Sync) -> Result<Table, String> {
        use rayon::prelude::*;
        let nodes: Vec<f64> = (0..n * n)
            .into_par_iter()
            .map(|k| node_dir(n, k % n, k / n).map_or(0.0, &f))
            .collect();
        Table::from_nodes(n, nodes)
    }

    /// A table from node values (row-major, y rows of x); normalized here.
    pub fn from_nodes(n: usize, mut nodes: Vec<f64>) -> Result<Table, String> {
        if n < 3 || nodes.len() != n * n {
            return Err(format!(
                "distribution table: {} values for {n} x {n} nodes; expected n >= 3 and n^2 values",
                nodes.len()
            ));
        }
        for (k, v) in nodes.iter_mut().enumerate() {
            if !v.is_finite() || *v < 0.0 {
                return Err(format!(
                    "distribution table: node {k} holds {v}; expected a finite non-negative density"
                ));
            }
            if node_dir(n, k % n, k / n).is_none() {
                *v = 0.0;
            }
        }
        let cell = 2.0 / (n - 1) as f64;
        let total: f64 = nodes.iter().sum::<f64>() * cell * cell;
        if !(total > 0.0) {
            return Err("distribution table: every node inside the disk is zero; expected a positive density".into());
        }
        let p: Vec<f32> = nodes.iter().map(|v| (v / total) as f32).collect();
        let g = compute_g(n, &p);
        let g_cells = CellCorners::new(&g, G_PHI, G_THETA);
        // A cell's mass is the mean of its corner nodes (the integral of its bilinear patch
        // over the cell's area, which is the same for every cell).
        let m = n - 1;
        let masses: Vec<f32> = (0..m * m)
            .map(|k| {
                let (i, j) = (k % m, k / m);
                let at = |i: usize, j: usize| p[j * n + i];
                0.25 * (at(i, j) + at(i + 1, j) + at(i, j + 1) + at(i + 1, j + 1))
            })
            .collect();
        let visible = VisibleSampler::new(n, &masses);
        Ok(Table {
            n,
            p,
            g,
            g_cells,
            visible,
        })
    }

    /// Bytes held by the node values, the g table and the sampler.
    pub fn memory_bytes(&self) -> usize {
        (self.p.len() + self.g.len()) * 4
            + self.g_cells.memory_bytes()
            + self.visible.memory_bytes()
    }

    pub fn resolution(&self) -> usize {
        self.n
    }

    /// Normalized node values (row-major, y rows of x).
    pub fn nodes(&self) -> &[f32] {
        &self.p
    }

    /// p(h), bilinear between nodes (h need not be normalized to the disk exactly), zero
    /// outside the unit disk.
    #[inline]
    pub fn p<T: Num>(&self, hx: T, hy: T) -> T {
        let s = T::of;
        let half_span = s((self.n - 1) as f64 / 2.0);
        let (px, py) = ((hx + s(1.0)) * half_span, (hy + s(1.0)) * half_span);
        let (ix, iy) = (node_index(px, self.n - 2), node_index(py, self.n - 2));
        let (fx, fy) = (px - T::of_int(ix), py - T::of_int(iy));
        let k = iy * T::int(self.n as i32) + ix;
        let at = |offset: i32| T::gather(&self.p, k + T::int(offset));
        let n = self.n as i32;
        let v = bilinear(fx, fy, [at(0), at(1), at(n), at(n + 1)]);
        select(le(s(1.0), hx * hx + hy * hy), s(0.0), v)
    }

    /// g(k) from its table, bilinear in (theta, phi).
    #[inline]
    pub fn g<T: Num>(&self, k: V3<T>) -> T {
        let s = T::of;
        let cos_t = minimum(maximum(k.z, s(-1.0)), s(1.0));
        let theta = minimum(to_degrees(acos(cos_t)), s(89.9)) / s(2.0);
        let phi = to_degrees(atan2(k.y, k.x));
        let phi = select(lt(phi, s(0.0)), phi + s(360.0), phi) / s(5.0);
        let (it, ip) = (node_index(theta, G_THETA - 2), node_index(phi, G_PHI - 2));
        let (ft, fp) = (theta - T::of_int(it), phi - T::of_int(ip));
        bilinear(fp, ft, self.g_cells.corners(ip, it))
    }

    /// The generator's value per unit specular colour (Schlick's Fresnel of
    /// reflectance `f0`).
    #[inline]
    pub fn rho<T: Num>(&self, wo: V3<T>, wi: V3<T>, f0: T) -> T {
        let zero = T::of(0.0);
        let h = (wo + wi).unit_or(V3::new(zero, zero, zero));
        self.rho_at(wo, wi, h, self.p(h.x, h.y), f0)
    }

    /// [`Table::rho`] given the half vector `h` of `wo` and `wi` (normalized or zero)
    /// and `p_h`, [`Table::p`] of it: callers that also need the density of `h` look p(h)
    /// up once.
    #[inline]
    pub fn rho_at<T: Num>(&self, wo: V3<T>, wi: V3<T>, h: V3<T>, p_h: T, f0: T) -> T {
        let (zero, one) = (T::of(0.0), T::of(1.0));
        let c = minimum(maximum(wi.dot(h), zero), one);
        let m = one - c;
        let m2 = m * m;
        let fresnel = f0 + (one - f0) * (m2 * m2 * m);
        let v = p_h * fresnel / (T::of(4.0) * self.g(wo) * self.g(wi));
        let ok = gt(wo.z, zero) & gt(wi.z, zero) & gt(h.z, zero) & is_finite(v);
        select(ok, maximum(v, zero), zero)
    }

    /// The density (solid angle of h) with which [`Table::sample_visible`] draws `h`
    /// seen from `wo`, given `p_h`, [`Table::p`] of `h`; in lanes (the visible-normal
    /// sampler's tables are read in lanes; one query is lane 0).
    #[inline]
    pub fn pdf_visible_at(&self, wo: Vec3xN, h: Vec3xN, p_h: f32xn) -> f32xn {
        self.visible.pdf(wo, h, p_h)
    }

    /// Half vectors visible from `wo` ([`VisibleSampler`]) from uniforms (`ux`, `uy`), and
    /// the mask of the lanes where one was drawn (the others hold no direction); `N` lane
    /// vectors side by side, each bit for bit its own call.
    #[inline]
    pub fn sample_visible<const N: usize>(
        &self,
        wo: [Vec3xN; N],
        ux: [f32xn; N],
        uy: [f32xn; N],
    ) -> [(Vec3xN, MaskN); N] {
        self.visible.sample(&self.p, wo, ux, uy)
    }

    /// Reads a distribution written by [`Table::write_exr`] (any square EXR; the first
    /// channel's values are the node densities, row 0 at h_y = -1).
    pub fn read_exr(path: &Path) -> Result<Table, String> {
        use exr::prelude::*;
        let name = path.display();
        crate::io::check_exr_size(path).map_err(|m| format!("{name}: {m}"))?;
        let img = crate::guard::third_party("OpenEXR", || {
            read_first_rgba_layer_from_file(
                path,
                |res, _| (res.width(), vec![0.0f64; res.width() * res.height()]),
                |(w, px): &mut (usize, Vec<f64>), pos, (r, _g, _b, _a): (f32, f32, f32, f32)| {
                    px[pos.y() * *w + pos.x()] = r as f64;
                },
            )
        })
        .map_err(|m| format!("{name}: {m}"))?
        .map_err(|e| format!("{name}: cannot read the distribution EXR: {e}"))?;
        let (w, px) = img.layer_data.channel_data.pixels;
        if w * w != px.len() {
            return Err(format!(
                "{name}: {} x {} pixels; expected a square distribution table",
                w,
                px.len() / w.max(1)
            ));
        }
        Table::from_nodes(w, px).map_err(|e| format!("{name}: {e}"))
    }

    /// Writes the table as an EXR file (temporary file renamed into place) that
    /// [`Table::read_exr`] and the `sampled-microfacet` material read.
    pub fn write_exr(&self, path: &Path) -> Result<(), crate::FileError> {
        let bytes = self
            .exr_bytes()
            .map_err(|e| crate::FileError::new(path.display().to_string(), e))?;
        crate::io::atomic_write(path, |w| std::io::Write::write_all(w, &bytes))
    }

    /// The node values as an EXR image (equal RGB channels).
    pub fn exr_bytes(&self) -> Result<Vec<u8>, String> {
        use exr::prelude::*;
        let n = self.n;
        let channels = SpecificChannels::rgb(|pos: exr::math::Vec2<usize>| {
            let v = self.p[pos.y() * n + pos.x()];
            (v, v, v)
        });
        let image = exr::image::Image::from_channels((n, n), channels);
        let mut buf = std::io::Cursor::new(Vec::new());
        image
            .write()
            .to_buffered(&mut buf)
            .map_err(|e| e.to_string())?;
        Ok(buf.into_inner())
    }
}

/// g(k) = int (h.k)+ p(h) dw = int_disk (h.k)+ p(h) / h_z dA on the (theta, phi) nodes.
fn compute_g(n: usize, p: &[f32]) -> Vec<f32> {
    use rayon::prelude::*;
    let cell = 2.0 / (n - 1) as f64;
    let nodes: Vec<(DVec3, f64)> = (0..n * n)
        .filter_map(|k| {
            let v = p[k] as f64;
            if v <= 0.0 {
                return None;
            }
            node_dir(n, k % n, k / n).map(|h| (h, v * cell * cell / h.z.max(1e-3)))
        })
        .collect();
    (0..G_THETA * G_PHI)
        .into_par_iter()
        .map(|k| {
            let d = g_dir(k / G_PHI, k % G_PHI);
            let s: f64 = nodes.iter().map(|(h, w)| h.dot(d).max(0.0) * w).sum();
            s.max(1e-6) as f32
        })
        .collect()
}

/// Pearson correlation of two tables' node values inside the disk (same resolution).
pub fn correlation(a: &Table, b: &Table) -> f64 {
    assert_eq!(a.n, b.n);
    let pairs: Vec<(f64, f64)> = (0..a.n * a.n)
        .filter(|&k| node_dir(a.n, k % a.n, k / a.n).is_some())
        .map(|k| (a.p[k] as f64, b.p[k] as f64))
        .collect();
    let m = pairs.len() as f64;
    let (ma, mb) = (
        pairs.iter().map(|p| p.0).sum::<f64>() / m,
        pairs.iter().map(|p| p.1).sum::<f64>() / m,
    );
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in pairs {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt().max(1e-300)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::microfacet_gen::synthetic::Shape;
    use crate::simd::{self, LANES};

    /// The f32 lane forms used for rendering agree with the f64 forms used for fitting
    /// to f32 precision (relative 2e-4: the tables are f32, the angles from fastmath),
    /// over directions covering the hemisphere, for a smooth and a sharply structured
    /// distribution; both give exactly zero below the surface.
    #[test]
    fn lane_forms_agree_with_f64_forms() {
        let satin = Shape::synthetic("satin").unwrap();
        for table in [
            Table::from_fn(65, |h| {
                (-(h.x * h.x + h.y * h.y) / (h.z * h.z * 0.09)).exp()
            })
            .unwrap(),
            Table::from_fn(129, |h| satin.density(h)).unwrap(),
        ] {
            let dir = |k: usize, a: f64, b: f64| {
                let z = ((k as f64 * a + 0.05).fract()) * 2.0 - 1.0;
                let phi = std::f64::consts::TAU * (k as f64 * b + 0.3).fract();
                let s = (1.0 - z * z).sqrt();
                DVec3::new(s * phi.cos(), s * phi.sin(), z)
            };
            let (mut checked, mut nonzero) = (0, 0);
            for chunk in 0..3200 / LANES {
                let wo: [DVec3; LANES] =
                    simd::lanes(|i| dir(LANES * chunk + i, 0.618_034, 0.414_214));
                let wi: [DVec3; LANES] =
                    simd::lanes(|i| dir(LANES * chunk + i + 3, 0.754_878, 0.569_840));
                let v8 = |d: &[DVec3; LANES]| Vec3xN::from_array(&simd::lanes(|i| d[i].as_vec3()));
                let rho = table.rho(v8(&wo), v8(&wi), f32xn::splat(0.3)).to_array();
                let g = table.g(v8(&wo)).to_array();
                for i in 0..LANES {
                    // The f64 form of the same f32 inputs.
                    let (o, w) = (wo[i].as_vec3().as_dvec3(), wi[i].as_vec3().as_dvec3());
                    let expected = table.rho(o.into(), w.into(), 0.3);
                    let tol = 2e-4 * expected + 1e-6;
                    assert!(
                        (rho[i] as f64 - expected).abs() <= tol,
                        "rho({o}, {w}) = {} in f32 lanes, {expected} in f64",
                        rho[i]
                    );
                    if o.z > 0.0 {
                        let ge = table.g(o.into());
                        assert!(
                            (g[i] as f64 - ge).abs() <= 2e-4 * ge,
                            "g({o}): {} vs {ge}",
                            g[i]
                        );
                    }
                    checked += 1;
                    nonzero += (expected > 0.0) as usize;
                }
            }
            assert!(
                checked == 3200 && nonzero > 500,
                "{nonzero} of {checked} non-zero"
            );
        }
    }
}
