//! A deterministic pseudo-random generator for the unit tests.

/// The next value of a linear congruential sequence, uniform in [−0.5, 0.5).
pub(crate) fn lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*state >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
}
