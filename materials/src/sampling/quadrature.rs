//! Gauss-Legendre quadrature (nodes by Newton's method on the Legendre recurrence, the
//! textbook construction of Numerical Recipes' `gauleg`), for the integrals over cylinder
//! cross-sections of the Poulin-Fournier model and for tabulating albedos.

use std::sync::OnceLock;

/// Nodes and weights of the n-point Gauss-Legendre rule on [-1, 1].
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = vec![(0.0, 0.0); n];
    let m = n.div_ceil(2);
    for i in 0..m {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut pp = 0.0;
        for _ in 0..100 {
            let (mut p1, mut p2) = (1.0, 0.0);
            for j in 0..n {
                let p3 = p2;
                p2 = p1;
                p1 = ((2 * j + 1) as f64 * z * p2 - j as f64 * p3) / (j + 1) as f64;
            }
            pp = n as f64 * (z * p1 - p2) / (z * z - 1.0);
            let z1 = z;
            z = z1 - p1 / pp;
            if (z - z1).abs() < 1e-15 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - z * z) * pp * pp);
        out[i] = (-z, w);
        out[n - 1 - i] = (z, w);
    }
    out
}

/// The 32-point rule, computed once.
pub fn gl32() -> &'static [(f64, f64)] {
    static RULE: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    RULE.get_or_init(|| gauss_legendre(32))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_polynomials_exactly() {
        let r = gauss_legendre(32);
        let sum_w: f64 = r.iter().map(|(_, w)| w).sum();
        assert!((sum_w - 2.0).abs() < 1e-13);
        // int_{-1}^{1} x^62 dx = 2 / 63
        let i: f64 = r.iter().map(|(x, w)| w * x.powi(62)).sum();
        assert!((i - 2.0 / 63.0).abs() < 1e-13, "{i}");
        let odd: f64 = r.iter().map(|(x, w)| w * x.powi(31)).sum();
        assert!(odd.abs() < 1e-14);
    }
}
