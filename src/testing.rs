//! Helpers for the unit tests.

/// A fixed pseudo-random sequence in [0, 1) from `seed` (a 64-bit linear congruential
/// generator, Knuth's MMIX constants, top 53 bits): each call advances the state, then maps it.
pub(crate) fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}
