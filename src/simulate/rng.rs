//! A small seeded pseudo-random generator (SplitMix64) for reproducible phases and noise.
//!
//! The library has no `rand` dependency; SplitMix64 (Steele, Lea & Flood, 2014) passes
//! BigCrush, needs 8 bytes of state and gives the same stream on every platform.

/// SplitMix64: `s ← s + 0x9E3779B97F4A7C15`, output a bijective mix of `s`.
///
/// Equal seeds give equal streams; neighbouring seeds give unrelated streams.
#[derive(Debug, Clone)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// A generator started from `seed`.
    pub fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform sample on `[0, 1)` with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// A standard normal sample N(0, 1) (Box–Muller on two uniforms).
    pub fn gaussian(&mut self) -> f64 {
        // 1 − U lies in (0, 1], so the logarithm is finite
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}
