//! Dörfler bulk marking (Dörfler, SIAM J. Numer. Anal. 33, 1996): the smallest set M of cells
//! with
//!
//! ```text
//! Σ_{T ∈ M} η_T² ≥ θ · Σ_T η_T²,        η_T² counted as max(η_T², 0)
//! ```
//!
//! Sorting the indicators in decreasing order and taking them until the partial sum reaches
//! the threshold gives a set of minimal cardinality; among the minimal sets it takes the cells
//! with the larger indicators, equal indicators in increasing cell order, so that the result is
//! deterministic.
//!
//! Edge cases, so that the function is total:
//! - θ ≥ 1 marks exactly the cells with a positive indicator (a cell with η_T² ≤ 0 never
//!   helps to reach any threshold); θ = 1 is the usual "mark everything that has an error".
//! - θ ≤ 0 (or NaN) marks nothing: the empty set already reaches the threshold.
//! - If no indicator is positive (an exact solution), nothing is marked.
//! - Negative and NaN indicators count as 0.
//!
//! The command line accepts only θ ∈ (0, 1] ([`check_theta`]).

use rayon::prelude::*;

use crate::error::{Error, Result};

/// The indicator as counted by the marking: max(η_T², 0), NaN as 0.
fn weight(v: f64) -> f64 {
    if v > 0.0 { v } else { 0.0 }
}

/// Refuses a bulk parameter outside (0, 1] with a usage error.
pub fn check_theta(theta: f64) -> Result<f64> {
    if theta > 0.0 && theta <= 1.0 {
        Ok(theta)
    } else {
        Err(Error::Usage(format!(
            "--mark {theta}: the Dörfler parameter θ must lie in (0, 1]"
        )))
    }
}

/// Marks the smallest set of cells holding at least the fraction `theta` of Σ max(η_T², 0)
/// (see the module documentation for ties and edge cases). O(n log n).
pub fn dorfler(eta_sq: &[f64], theta: f64) -> Vec<bool> {
    let n = eta_sq.len();
    let mut marked = vec![false; n];
    if theta.is_nan() || theta <= 0.0 {
        return marked;
    }
    if theta >= 1.0 {
        for (m, &v) in marked.iter_mut().zip(eta_sq) {
            *m = weight(v) > 0.0;
        }
        return marked;
    }
    let mut order: Vec<usize> = (0..n).filter(|&t| weight(eta_sq[t]) > 0.0).collect();
    order.par_sort_unstable_by(|&a, &b| {
        weight(eta_sq[b])
            .total_cmp(&weight(eta_sq[a]))
            .then(a.cmp(&b))
    });
    // The total summed in the same order as the partial sums, so that the last partial sum is
    // the total bit for bit.
    let total: f64 = order.iter().map(|&t| eta_sq[t]).fold(0.0, |s, v| s + v);
    let threshold = theta * total;
    let mut sum = 0.0;
    for &t in &order {
        if sum >= threshold {
            break;
        }
        sum += eta_sq[t];
        marked[t] = true;
    }
    marked
}

/// Fraction of Σ max(η_T², 0) held by the marked cells (0 when the total is 0).
pub fn share(eta_sq: &[f64], marked: &[bool]) -> f64 {
    let total: f64 = eta_sq.iter().map(|&v| weight(v)).sum();
    let held: f64 = eta_sq
        .iter()
        .zip(marked)
        .filter(|(_, m)| **m)
        .map(|(&v, _)| weight(v))
        .sum();
    if total > 0.0 { held / total } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn set(m: &[bool]) -> Vec<usize> {
        (0..m.len()).filter(|&i| m[i]).collect()
    }

    #[test]
    fn hand_examples() {
        let e = [1.0, 4.0, 2.0, 3.0];
        // Σ = 10: θ = 0.4 → {1} (4 ≥ 4); θ = 0.5 → {1, 3} (7 ≥ 5); θ = 0.7 → {1, 3} (7 ≥ 7).
        assert_eq!(set(&dorfler(&e, 0.4)), vec![1]);
        assert_eq!(set(&dorfler(&e, 0.5)), vec![1, 3]);
        assert_eq!(set(&dorfler(&e, 0.7)), vec![1, 3]);
        assert_eq!(set(&dorfler(&e, 0.71)), vec![1, 2, 3]);
        assert_eq!(set(&dorfler(&e, 0.95)), vec![0, 1, 2, 3]);
        assert!((share(&e, &dorfler(&e, 0.5)) - 0.7).abs() < 1e-15);
    }

    #[test]
    fn ties_go_to_the_lower_index() {
        let e = [1.0, 1.0, 1.0, 1.0];
        assert_eq!(set(&dorfler(&e, 0.5)), vec![0, 1]);
        assert_eq!(set(&dorfler(&e, 0.51)), vec![0, 1, 2]);
        let e = [0.5, 2.0, 0.5, 2.0, 0.5];
        assert_eq!(set(&dorfler(&e, 0.8)), vec![0, 1, 3]);
        assert_eq!(set(&dorfler(&e, 0.9)), vec![0, 1, 2, 3]);
    }

    #[test]
    fn negative_and_nan_indicators_count_as_zero() {
        // Σ max(η², 0) = 4, not 4 − 3.
        let e = [-3.0, 3.0, f64::NAN, 1.0];
        assert_eq!(set(&dorfler(&e, 0.75)), vec![1]);
        assert_eq!(set(&dorfler(&e, 0.76)), vec![1, 3]);
        assert_eq!(set(&dorfler(&e, 1.0)), vec![1, 3]);
        assert!((share(&e, &dorfler(&e, 0.75)) - 0.75).abs() < 1e-15);
    }

    #[test]
    fn theta_edge_cases() {
        let e = [1.0, 0.0, 1e-300, 2.0];
        assert_eq!(set(&dorfler(&e, 1.0)), vec![0, 2, 3]);
        assert_eq!(set(&dorfler(&e, 1.5)), vec![0, 2, 3]);
        assert!(set(&dorfler(&e, 0.0)).is_empty());
        assert!(set(&dorfler(&e, -1.0)).is_empty());
        assert!(set(&dorfler(&e, f64::NAN)).is_empty());
        // The smallest positive θ still marks the largest cell.
        assert_eq!(set(&dorfler(&e, f64::MIN_POSITIVE)), vec![3]);
        // Nothing to mark.
        assert!(set(&dorfler(&[0.0, -1.0], 0.5)).is_empty());
        assert!(dorfler(&[], 0.5).is_empty());
        assert_eq!(share(&[0.0, -1.0], &[true, true]), 0.0);
        assert!(check_theta(0.5).is_ok() && check_theta(1.0).is_ok());
        for bad in [0.0, -0.1, 1.01, f64::NAN] {
            let e = check_theta(bad).unwrap_err().to_string();
            assert!(e.contains("(0, 1]"), "{e}");
        }
    }

    #[test]
    fn large_input_is_fast_and_minimal() {
        let n = 200_000;
        let e: Vec<f64> = (0..n)
            .map(|i| ((i as f64 * 0.618_033_988_75).fract() + 1e-3).powi(3))
            .collect();
        let m = dorfler(&e, 0.6);
        let total: f64 = e.iter().sum();
        let mut held: Vec<f64> = e.iter().zip(&m).filter(|p| *p.1).map(|p| *p.0).collect();
        held.sort_by(f64::total_cmp);
        let sum: f64 = held.iter().sum();
        assert!(sum >= 0.6 * total * (1.0 - 1e-12));
        assert!(sum - held[0] < 0.6 * total);
        // Every unmarked cell is no larger than every marked one.
        let max_unmarked = e
            .iter()
            .zip(&m)
            .filter(|p| !*p.1)
            .map(|p| *p.0)
            .fold(0.0, f64::max);
        assert!(max_unmarked <= held[0]);
    }

    /// Minimum cardinality of a set of cells reaching θ Σ, by brute force.
    fn brute_force_minimum(w: &[f64], theta: f64) -> usize {
        let total: f64 = w.iter().sum();
        (0u32..1 << w.len())
            .filter(|s| {
                let sum: f64 = (0..w.len()).filter(|i| s >> i & 1 == 1).map(|i| w[i]).sum();
                sum >= theta * total
            })
            .map(|s| s.count_ones() as usize)
            .min()
            .unwrap_or(0)
    }

    proptest! {
        #[test]
        fn marked_set_is_minimal(
            // Multiples of 1/8 keep every sum exact, so brute force and greedy agree exactly.
            e in proptest::collection::vec(-8i32..40, 1..11),
            theta_num in 1u32..=20,
        ) {
            let e: Vec<f64> = e.iter().map(|&v| v as f64 / 8.0).collect();
            let theta = theta_num as f64 / 20.0;
            let m = dorfler(&e, theta);
            let w: Vec<f64> = e.iter().map(|&v| v.max(0.0)).collect();
            let total: f64 = w.iter().sum();
            let held: Vec<f64> = (0..e.len()).filter(|&i| m[i]).map(|i| w[i]).collect();
            let sum: f64 = held.iter().sum();
            // Reaches the threshold, only positive cells, minimal cardinality, and removing the
            // smallest marked cell drops below the threshold.
            prop_assert!(sum >= theta * total);
            prop_assert!(held.iter().all(|&v| v > 0.0));
            if theta < 1.0 {
                prop_assert_eq!(held.len(), brute_force_minimum(&w, theta));
                if let Some(min) = held.iter().copied().reduce(f64::min) {
                    prop_assert!(sum - min < theta * total);
                }
            } else {
                prop_assert_eq!(held.len(), w.iter().filter(|&&v| v > 0.0).count());
            }
        }
    }
}
