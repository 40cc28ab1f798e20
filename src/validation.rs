//! Validation statistics of a fit: is the cost what the noise explains, and are the
//! normalised residuals white across frequency?
//!
//! With residuals r_k = (Y_k − Ŷ_k)/σ_k normalised by the noise model, a correct model and
//! exact variances give V = Σ|r_k|² ~ ½χ²(2N − p): E V = N − p/2 (the ML cost of McKelvey
//! eq. 23 at its minimum). With sample variances from P periods each |r_k|² follows
//! F(2, 2ν), ν = P − 1; the cost is then compared with a scaled χ² of the same mean and
//! variance. Whiteness: the complex Ljung–Box statistic over lags l = 1 … m,
//! Q = Σ_l 2N²|ρ̂_l|²/(N − l) ~ χ²(2m), ρ̂_l = Σ_k r_{k+l} r̄_k / Σ_k |r_k|².

use crate::model::Domain;
use crate::scalar::{Complex, Real};
use crate::stats::chi2_sf;
use num_traits::Float;

/// The poles among `poles` (of a model in `domain`) whose half-power band holds none of the
/// data lines `omega` (rad/s, ascending), so that the data do not determine their damping:
/// with s = p (continuous time) or s = ln(p)/Ts (discrete time), s = σ + iω_p, a pole is
/// unresolved when ω_p lies inside the band of the data and no line ω_k satisfies
/// |ω_k − |ω_p|| ≤ |σ|. One conjugate of each pair is listed (the one with Im p ≥ 0).
/// Such a pole is typically spurious — a resonance fitted between two lines — even when
/// the cost looks right.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::model::Domain;
/// use fdid::validation::unresolved_poles;
/// let omega: Vec<f64> = (1..=100).map(|k| k as f64).collect(); // lines 1 rad/s apart
/// let poles = [Complex::new(-1e-3, 10.5), Complex::new(-1e-3, -10.5), Complex::new(-2.0, 20.0)];
/// // the first pair's band (10.5 ± 0.001 rad/s) falls between two lines
/// assert_eq!(unresolved_poles(&poles, Domain::Continuous, &omega), vec![poles[0]]);
/// ```
pub fn unresolved_poles<T: Real>(
    poles: &[Complex<T>],
    domain: Domain<T>,
    omega: &[T],
) -> Vec<Complex<T>> {
    poles
        .iter()
        .filter(|p| p.im >= T::zero())
        .filter(|p| lines_in_band(s_plane(domain, **p), omega) == Some(0))
        .copied()
        .collect()
}

/// The s-plane pole s = p (continuous time) or s = ln(p)/Ts (discrete time) of a pole p
/// of a model in `domain`.
pub(crate) fn s_plane<T: Real>(domain: Domain<T>, p: Complex<T>) -> Complex<T> {
    match domain {
        Domain::Continuous => p,
        Domain::Discrete { ts } => p.ln() / ts,
    }
}

/// How many of the lines `omega` (rad/s, ascending) lie in the half-power band of the
/// s-plane pole s = σ + iω_p, |ω_k − |ω_p|| ≤ |σ|, counted up to 2 (2 means two or more);
/// `None` when |ω_p| lies outside the band of the data [ω_1, ω_N].
pub(crate) fn lines_in_band<T: Real>(s: Complex<T>, omega: &[T]) -> Option<usize> {
    let (lo, hi) = (*omega.first()?, *omega.last()?);
    let (sigma, w) = (Float::abs(s.re), Float::abs(s.im));
    if !(w >= lo && w <= hi) {
        return None;
    }
    // the first line at or above w − σ
    let first = omega.partition_point(|x| *x < w - sigma);
    let inside = |k: usize| omega.get(k).is_some_and(|x| *x <= w + sigma);
    Some((first..first + 2).take_while(|k| inside(*k)).count())
}

/// Damping ratio under which a pole counts as on the stability boundary
/// ([`marginal_poles`]).
pub const MARGINAL_DAMPING: f64 = 1e-6;

/// Distance from the stability boundary, as a fraction of the lowest positive data
/// frequency, under which a pole counts as on it ([`marginal_poles`]).
pub const BELOW_BAND: f64 = 1e-4;

/// The poles among `poles` (of a model in `domain`, fitted on the lines `omega`, rad/s)
/// that sit on the stability boundary, with s = p (continuous time) or s = ln(p)/Ts
/// (discrete time): a damping ratio ζ = −Re s/|s| below [`MARGINAL_DAMPING`] (a
/// resonance that a stability-constrained fit stopped at the boundary), or a distance
/// −Re s from the boundary below [`BELOW_BAND`] times ω_lo, the lowest positive line: a
/// pole so close to s = 0 that over the band it changes an integrator's response by less
/// than that fraction, so the data cannot tell it from an integrator or an unstable pole.
/// Unstable poles (Re s > 0) count too. Neither kind is a pole the data determine; both
/// conjugates of a pair are listed.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::model::Domain;
/// use fdid::validation::marginal_poles;
/// let omega: Vec<f64> = (1..=100).map(|k| k as f64).collect(); // 1..100 rad/s
/// let poles = [Complex::new(-1e-9, 20.0), Complex::new(-1e-9, -20.0), // ζ = 5e-11
///              Complex::new(-1e-6, 0.0),                              // next to s = 0
///              Complex::new(-0.5, 0.0), Complex::new(-2.0, 30.0)];     // determined
/// assert_eq!(marginal_poles(&poles, Domain::Continuous, &omega), poles[..3].to_vec());
/// ```
pub fn marginal_poles<T: Real>(
    poles: &[Complex<T>],
    domain: Domain<T>,
    omega: &[T],
) -> Vec<Complex<T>> {
    let lowest = omega
        .iter()
        .copied()
        .filter(|w| *w > T::zero())
        .fold(T::infinity(), Float::min);
    let lowest = if Float::is_finite(lowest) {
        lowest
    } else {
        T::zero()
    };
    poles
        .iter()
        .filter(|p| {
            let s = s_plane(domain, **p);
            let distance = -s.re;
            distance < T::lit(MARGINAL_DAMPING) * s.norm() || distance < T::lit(BELOW_BAND) * lowest
        })
        .copied()
        .collect()
}

/// The validation statistics of one fit (see the module docs).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Validation {
    /// The cost V = Σ|r_k|².
    pub cost: f64,
    /// E V under the noise model: N − p/2, times N_F = ν/(ν − 2) (ν = 2·dof) for sample
    /// variances; `None` when the noise level is estimated from the residuals (flat
    /// weighting) or the mean does not exist (dof = 1).
    pub cost_expected: Option<f64>,
    /// P(V′ ≥ V) for V′ distributed as the cost of a correct model: small values say the
    /// model leaves more than noise. `None` when `cost_expected` is, or dof ≤ 2.
    pub cost_p: Option<f64>,
    /// Number of lags m of the whiteness test.
    pub whiteness_lags: usize,
    /// The Ljung–Box statistic Q (`None` below 8 lines).
    pub whiteness_q: Option<f64>,
    /// P(χ²(2m) ≥ Q): small values say the residuals are correlated across frequency.
    pub whiteness_p: Option<f64>,
    /// max_k |r_k| (for a noise-normalised fit: in noise standard deviations).
    pub max_residual: f64,
}

impl Validation {
    /// Statistics of the normalised residuals `r` of a model with `params` parameters.
    /// `noise_known`: r is normalised by the true noise level (else by nothing, and the
    /// cost test is skipped); `dof`: degrees of freedom of sample variances.
    pub fn new<T: Real>(
        r: &[Complex<T>],
        params: usize,
        noise_known: bool,
        dof: Option<usize>,
    ) -> Self {
        // in f64 (borrowed when T is f64)
        let r = T::complex_as_f64(r);
        let r: &[Complex<f64>] = &r;
        let n = r.len();
        let cost: f64 = r.iter().map(|v| v.norm_sqr()).sum();
        let n_eff = n as f64 - params as f64 / 2.0;
        let (cost_expected, cost_p) = if noise_known && n_eff > 0.0 {
            cost_test(cost, n_eff, dof)
        } else {
            (None, None)
        };
        let lags = if n >= 8 { (n / 4).clamp(1, 20) } else { 0 };
        let (whiteness_q, whiteness_p) = if lags > 0 && cost > 0.0 {
            let parts = Parts::of(r);
            let q: f64 = (1..=lags)
                .map(|l| {
                    let rho = parts.lagged_product(l) / cost;
                    2.0 * (n * n) as f64 * rho.norm_sqr() / (n - l) as f64
                })
                .sum();
            (Some(q), Some(chi2_sf(q, 2.0 * lags as f64)))
        } else {
            (None, None)
        };
        // √max|r|² unless that overflows
        let max_residual = Some(r.iter().map(|v| v.norm_sqr()).fold(0.0, f64::max).sqrt())
            .filter(|m| m.is_finite())
            .unwrap_or_else(|| r.iter().map(|v| v.norm()).fold(0.0, f64::max));
        Self {
            cost,
            cost_expected,
            cost_p,
            whiteness_lags: lags,
            whiteness_q,
            whiteness_p,
            max_residual,
        }
    }
}

/// The real and imaginary parts of residuals in two arrays, so that the four lanes of
/// [`Parts::lagged_product`] are read as vectors.
struct Parts {
    re: Vec<f64>,
    im: Vec<f64>,
}

impl Parts {
    fn of(r: &[Complex<f64>]) -> Self {
        Self {
            re: r.iter().map(|v| v.re).collect(),
            im: r.iter().map(|v| v.im).collect(),
        }
    }

    /// Σ_{k ≥ l} r_k r̄_{k−l}, summed in four independent lanes (lane i holds the lines
    /// k ≡ l + i mod 4 of the first 4⌊(N − l)/4⌋; a single running sum is a chain of
    /// dependent additions), then the lanes and the last lines in turn; for l < N.
    fn lagged_product(&self, l: usize) -> Complex<f64> {
        const LANES: usize = 4;
        let n = self.re.len();
        let (ar, ai) = (&self.re[l..], &self.im[l..]);
        let (br, bi) = (&self.re[..n - l], &self.im[..n - l]);
        let mut re = [0.0; LANES];
        let mut im = [0.0; LANES];
        let (a_re, a_im) = (ar.as_chunks::<LANES>().0, ai.as_chunks::<LANES>().0);
        let (b_re, b_im) = (br.as_chunks::<LANES>().0, bi.as_chunks::<LANES>().0);
        // the real and the imaginary sums in two loops of plain lane-wise vector arithmetic
        for c in 0..a_re.len() {
            let (ar, ai, br, bi) = (&a_re[c], &a_im[c], &b_re[c], &b_im[c]);
            for i in 0..LANES {
                re[i] += ar[i] * br[i] + ai[i] * bi[i];
            }
        }
        for c in 0..a_re.len() {
            let (ar, ai, br, bi) = (&a_re[c], &a_im[c], &b_re[c], &b_im[c]);
            for i in 0..LANES {
                im[i] += ai[i] * br[i] - ar[i] * bi[i];
            }
        }
        let done = ar.len() - ar.len() % LANES;
        let rest = (done..ar.len()).fold(Complex::new(0.0, 0.0), |s, k| {
            let (a, b) = (Complex::new(ar[k], ai[k]), Complex::new(br[k], bi[k]));
            s + a * b.conj()
        });
        Complex::new(re.iter().sum::<f64>(), im.iter().sum::<f64>()) + rest
    }
}

/// Expected cost and upper-tail probability for `n_eff` = N − p/2 complex residuals.
fn cost_test(cost: f64, n_eff: f64, dof: Option<usize>) -> (Option<f64>, Option<f64>) {
    match dof {
        None => (Some(n_eff), Some(chi2_sf(2.0 * cost, 2.0 * n_eff))),
        Some(dof) => {
            let d2 = 2.0 * dof as f64;
            if d2 <= 2.0 {
                return (None, None);
            }
            // |r|² ~ F(2, d2): mean d2/(d2 − 2), variance d2³/((d2 − 2)²(d2 − 4))
            let mean = n_eff * d2 / (d2 - 2.0);
            if d2 <= 4.0 {
                return (Some(mean), None);
            }
            let var = n_eff * d2 * d2 * d2 / ((d2 - 2.0) * (d2 - 2.0) * (d2 - 4.0));
            // V ≈ c χ²(f) with the same mean and variance
            let c = var / (2.0 * mean);
            let f = 2.0 * mean * mean / var;
            (Some(mean), Some(chi2_sf(cost / c, f)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lagged_products_match_the_definition() {
        let r: Vec<Complex<f64>> = (0..23)
            .map(|k| Complex::new((k as f64 * 0.7).sin(), (k as f64 * 1.3).cos() - 0.2))
            .collect();
        let parts = Parts::of(&r);
        for l in 0..r.len() {
            let want = (l..r.len()).fold(Complex::new(0.0, 0.0), |s, k| s + r[k] * r[k - l].conj());
            assert!((parts.lagged_product(l) - want).norm() <= 1e-13, "lag {l}");
        }
    }

    #[test]
    fn lagged_products_are_summed_lane_by_lane_in_line_order() {
        // lane i: the lines l + i, l + i + 4, … in turn; then the lanes; then the rest
        let lanes = |r: &[Complex<f64>], l: usize| {
            let (head, tail) = (&r[..r.len() - l], &r[l..]);
            let mut sum = [Complex::new(0.0, 0.0); 4];
            let full = tail.len() - tail.len() % 4;
            for k in 0..full {
                let (a, b) = (tail[k], head[k]);
                let s = &mut sum[k % 4];
                s.re += a.re * b.re + a.im * b.im;
                s.im += a.im * b.re - a.re * b.im;
            }
            let rest = (full..tail.len())
                .fold(Complex::new(0.0, 0.0), |s, k| s + tail[k] * head[k].conj());
            let re: f64 = sum.iter().map(|s| s.re).sum();
            let im: f64 = sum.iter().map(|s| s.im).sum();
            Complex::new(re, im) + rest
        };
        let mut state = 3u64;
        for n in [8, 9, 10, 11, 37, 200] {
            let r: Vec<Complex<f64>> = (0..n)
                .map(|_| {
                    let re = crate::test_rng::lcg(&mut state);
                    Complex::new(re, crate::test_rng::lcg(&mut state))
                })
                .collect();
            let parts = Parts::of(&r);
            for l in 1..n.min(21) {
                let (got, want) = (parts.lagged_product(l), lanes(&r, l));
                let bits = |c: Complex<f64>| (c.re.to_bits(), c.im.to_bits());
                assert_eq!(bits(got), bits(want), "N = {n}, lag {l}");
            }
        }
    }

    #[test]
    fn the_largest_residual_survives_overflow_of_its_square() {
        let r = [Complex::new(3e200, 4e200), Complex::new(1.0, 0.0)];
        let v = Validation::new(&r, 1, false, None);
        assert!((v.max_residual / 5e200 - 1.0).abs() <= 1e-15);
        let v = Validation::new(&[Complex::new(3.0, -4.0)], 1, false, None);
        assert_eq!(v.max_residual, 5.0);
    }

    #[test]
    fn lines_in_a_half_power_band_are_counted_up_to_two() {
        let omega: Vec<f64> = (1..=10).map(f64::from).collect();
        let band = |sigma: f64, w: f64| lines_in_band(Complex::new(-sigma, w), &omega);
        assert_eq!(band(0.1, 4.5), Some(0));
        assert_eq!(band(0.1, 4.95), Some(1));
        // both edges count: |ω_k − ω_p| ≤ |σ|
        assert_eq!(band(0.5, 4.5), Some(2));
        assert_eq!(band(3.0, 5.0), Some(2));
        assert_eq!(band(0.1, -4.95), Some(1));
        assert_eq!(band(0.1, 0.5), None);
        assert_eq!(band(0.1, 10.5), None);
        assert_eq!(lines_in_band(Complex::new(-0.1, 1.0), &[] as &[f64]), None);
    }
}
