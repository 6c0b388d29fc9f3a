//! Small dense kernels shared by the per-patch and per-cell problems (`reconstruct::qp`,
//! `estimate::symmetric`): hand-written for sizes of a few dozen, where a library call's setup
//! costs more than the arithmetic.

/// Cholesky factor L (row-major, stride m) of G restricted to `set`; false if not positive.
pub fn cholesky(m: usize, g: &[f64], set: &[usize], l: &mut [f64]) -> bool {
    let k = set.len();
    for i in 0..k {
        for j in 0..=i {
            let mut s = g[set[i] * m + set[j]];
            for t in 0..j {
                s -= l[i * m + t] * l[j * m + t];
            }
            if i == j {
                // Also rejects NaN.
                if s.is_nan() || s <= 0.0 {
                    return false;
                }
                l[i * m + i] = s.sqrt();
            } else {
                l[i * m + j] = s / l[j * m + j];
            }
        }
    }
    true
}

/// Solves L Lᵀ y = v in place (L from [`cholesky`], k × k).
pub fn cholesky_solve(m: usize, k: usize, l: &[f64], v: &mut [f64]) {
    for i in 0..k {
        let mut s = v[i];
        for t in 0..i {
            s -= l[i * m + t] * v[t];
        }
        v[i] = s / l[i * m + i];
    }
    for i in (0..k).rev() {
        let mut s = v[i];
        for t in i + 1..k {
            s -= l[t * m + i] * v[t];
        }
        v[i] = s / l[i * m + i];
    }
}
