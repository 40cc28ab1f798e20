//! The passivity check of a scattering model: ‖S(iω)‖₂ ≤ 1 at every frequency.

use super::model::CommonPoleModel;
use crate::scalar::Real;
use nalgebra::DMatrix;
use num_complex::Complex;
use num_traits::Float;

/// How far above 1 the largest singular value may be before a grid point counts as a
/// violation: rounding and the fit error of a lossless port (|S₁₁(0)| = 1 for a series
/// capacitor) reach 10⁻⁷, far below any physical gain.
pub const PASSIVITY_TOLERANCE: f64 = 1e-6;

/// The largest singular value of a scattering model's S over a dense grid.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Passivity<T: Real> {
    /// max over the grid of σ_max(S).
    pub max_singular_value: T,
    /// Where it is reached (Hz).
    pub at_hz: T,
    /// Grid points where σ_max(S) > 1 + [`PASSIVITY_TOLERANCE`].
    pub violations: usize,
    /// Grid points checked.
    pub points: usize,
}

impl<T: Real> Passivity<T> {
    /// True when no grid point violates σ_max(S) ≤ 1 + [`PASSIVITY_TOLERANCE`].
    pub fn passive(&self) -> bool {
        self.violations == 0
    }
}

/// Checks σ_max(S(iω)) ≤ 1 for a scattering model on `points` evenly spaced frequencies
/// from 0 to 1.5 times `f_max_hz` together with the natural frequency of every pole and
/// points on its flanks (where a violation peaks), the test of a passive n-port (a reciprocal lossless network has
/// σ_max = 1). A sampled check: a violation narrower than the grid can escape it.
///
/// σ_max is computed only where the bounds max_j ‖S e_j‖ ≤ σ_max(S) ≤ ‖S‖_F leave the
/// answer open: at the points whose upper bound reaches the largest lower bound over the grid
/// (one of them holds the maximum) and those whose bounds straddle 1 + tolerance (the
/// violation count); the result is the one σ_max at every point gives.
pub fn passivity<T: Real>(model: &CommonPoleModel<T>, f_max_hz: T, points: usize) -> Passivity<T> {
    let omega = frequency_grid(model, f_max_hz, points);
    let responses = model.response(&omega);
    let limit = T::one() + T::lit(PASSIVITY_TOLERANCE);
    let bounds: Vec<(T, T)> = responses.iter().map(singular_value_bounds).collect();
    let mut largest: Vec<Option<T>> = vec![None; omega.len()];
    let exact = |ks: &[usize], largest: &mut Vec<Option<T>>| {
        let values = crate::linalg::parallel::map_indices(ks.len(), |i| {
            largest_singular_value(&responses[ks[i]])
        });
        for (k, s) in ks.iter().zip(values) {
            largest[*k] = Some(s);
        }
    };
    // the maximum: points by descending upper bound, until the bound falls below the
    // largest value found (the Frobenius norm may round below σ_max of a rank-one S)
    let slack = T::one() + T::lit(1e-12);
    let mut order: Vec<usize> = (0..omega.len()).collect();
    order.sort_by(|a, b| {
        bounds[*b]
            .1
            .partial_cmp(&bounds[*a].1)
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut floor = bounds.iter().map(|b| b.0).fold(T::zero(), Float::max);
    for batch in order.chunks(256) {
        let open: Vec<usize> = batch
            .iter()
            .copied()
            .filter(|&k| !(bounds[k].1 * slack < floor))
            .collect();
        if open.is_empty() {
            break;
        }
        exact(&open, &mut largest);
        floor = open
            .iter()
            .filter_map(|k| largest[*k])
            .fold(floor, Float::max);
    }
    // the violations: the points whose bounds straddle the limit
    let straddling: Vec<usize> = (0..omega.len())
        .filter(|&k| {
            let (lower, upper) = bounds[k];
            largest[k].is_none() && !(lower > limit) && !(upper * slack <= limit)
        })
        .collect();
    exact(&straddling, &mut largest);
    let mut worst = (T::zero(), T::zero());
    let mut violations = 0;
    for (k, w) in omega.iter().enumerate() {
        let lower = bounds[k].0;
        let violates = match largest[k] {
            Some(s) => {
                if !(s <= worst.0) {
                    worst = (s, *w / T::two_pi());
                }
                s > limit
            }
            None => lower > limit,
        };
        if violates {
            violations += 1;
        }
    }
    Passivity {
        max_singular_value: worst.0,
        at_hz: worst.1,
        violations,
        points: omega.len(),
    }
}

/// Bounds on the largest singular value of `s`: the largest column norm below, the
/// Frobenius norm above; both infinite when an entry is not finite (that point is then
/// checked first and counts as a violation, as a failed SVD did).
fn singular_value_bounds<T: Real>(s: &DMatrix<Complex<T>>) -> (T, T) {
    let mut frobenius = T::zero();
    let mut column = T::zero();
    for c in s.column_iter() {
        let power = c.iter().fold(T::zero(), |acc, v| acc + v.norm_sqr());
        frobenius += power;
        column = Float::max(column, power);
    }
    if Float::is_finite(frobenius) {
        (Float::sqrt(column), Float::sqrt(frobenius))
    } else {
        (T::infinity(), T::infinity())
    }
}

/// σ_max(s) as √λ_max of the smaller Hermitian product sᴴs or ssᴴ (its eigenvalues are
/// the squared singular values; the largest is held to about ε‖s‖², far inside the
/// check's tolerance); infinite when the eigenvalue iteration fails.
fn largest_singular_value<T: Real>(s: &DMatrix<Complex<T>>) -> T {
    if s.iter()
        .any(|v| !(Float::is_finite(v.re) && Float::is_finite(v.im)))
    {
        return T::infinity();
    }
    let gram = if s.ncols() <= s.nrows() {
        s.ad_mul(s)
    } else {
        s * s.adjoint()
    };
    nalgebra::SymmetricEigen::try_new(gram, T::default_epsilon(), 1000)
        .map(|e| {
            let top = e.eigenvalues.iter().copied().fold(T::zero(), Float::max);
            Float::sqrt(top)
        })
        .unwrap_or(T::infinity())
}

/// The check's frequencies (rad/s, ascending): `points` evenly spaced from 0 to 1.5 times
/// `f_max_hz`, the natural frequency of every pole and, within that range, 8 points on
/// its flanks (±¼, ½, 1, 2 half-bandwidths).
pub(crate) fn frequency_grid<T: Real>(
    model: &CommonPoleModel<T>,
    f_max_hz: T,
    points: usize,
) -> Vec<T> {
    let top = f_max_hz * T::lit(1.5) * T::two_pi();
    let mut omega: Vec<T> = (0..points.max(2))
        .map(|k| top * T::from_usize_lossy(k) / T::from_usize_lossy(points.max(2) - 1))
        .collect();
    // each resonance's peak and its flanks, at a quarter to twice its half-bandwidth
    // |Re p| (in z, |ln|p||/ts) on either side: an evenly spaced grid over a wide band
    // steps over the peak of a lightly damped low-frequency mode
    for p in model.poles.slots() {
        let (w, half_width) = match model.domain {
            crate::model::Domain::Continuous => (Float::abs(p.im), Float::abs(p.re)),
            crate::model::Domain::Discrete { ts } => (
                Float::abs(p.arg()) / ts,
                Float::abs(Float::ln(p.norm())) / ts,
            ),
        };
        omega.push(w);
        for offset in [0.25, 0.5, 1.0, 2.0] {
            for side in [-1.0, 1.0] {
                let at = w + T::lit(side * offset) * half_width;
                if at >= T::zero() && at <= top {
                    omega.push(at);
                }
            }
        }
    }
    omega.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    omega
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mimo::PoleSet;
    use crate::model::Domain;

    /// A 3 × 2 (or square) continuous-time model with seeded residues scaled by `gain`.
    fn model(ny: usize, nu: usize, gain: f64) -> CommonPoleModel<f64> {
        let pairs: Vec<Complex<f64>> = (0..6)
            .map(|k| {
                let w = 1.0 + 1.7 * k as f64;
                Complex::new(-0.02 * w, w)
            })
            .collect();
        let slots = 1 + pairs.len();
        let residues = (0..slots)
            .map(|m| {
                DMatrix::from_fn(ny, nu, |i, j| {
                    let t = (m * 7 + i * 3 + j * 5) as f64;
                    let im = if m == 0 { 0.0 } else { t.cos() };
                    Complex::new(t.sin(), im) * gain * 0.05
                })
            })
            .collect();
        CommonPoleModel {
            domain: Domain::Continuous,
            poles: PoleSet {
                real: vec![-0.5],
                pairs,
            },
            residues,
            direct: Some(DMatrix::from_fn(ny, nu, |i, j| 0.02 * (i + 2 * j) as f64)),
        }
    }

    /// The check with σ_max from the SVD at every grid point.
    fn brute_force(m: &CommonPoleModel<f64>, f_max_hz: f64, points: usize) -> Passivity<f64> {
        let omega = frequency_grid(m, f_max_hz, points);
        let mut worst = (0.0, 0.0);
        let mut violations = 0;
        for (w, s) in omega.iter().zip(m.response(&omega)) {
            let top = s.singular_values().max();
            if top > 1.0 + PASSIVITY_TOLERANCE {
                violations += 1;
            }
            if top > worst.0 {
                worst = (top, w / std::f64::consts::TAU);
            }
        }
        Passivity {
            max_singular_value: worst.0,
            at_hz: worst.1,
            violations,
            points: omega.len(),
        }
    }

    #[test]
    fn bounded_check_matches_the_svd_at_every_point() {
        for (ny, nu) in [(3, 2), (2, 3), (4, 4), (1, 1)] {
            for gain in [0.05, 1.0, 5.0] {
                let m = model(ny, nu, gain);
                let fast = passivity(&m, 2.0, 600);
                let slow = brute_force(&m, 2.0, 600);
                let rel = (fast.max_singular_value - slow.max_singular_value).abs()
                    / slow.max_singular_value;
                assert!(rel < 1e-12, "{ny}x{nu} gain {gain}: {rel:e}");
                assert_eq!(fast.at_hz, slow.at_hz, "{ny}x{nu} gain {gain}");
                assert_eq!(fast.violations, slow.violations, "{ny}x{nu} gain {gain}");
                assert_eq!(fast.points, slow.points);
            }
        }
        // the scaled models cover both verdicts
        assert!(passivity(&model(3, 2, 0.05), 2.0, 600).passive());
        assert!(!passivity(&model(3, 2, 5.0), 2.0, 600).passive());
    }

    #[test]
    fn a_response_that_is_not_finite_is_a_violation() {
        let mut m = model(2, 2, 1.0);
        m.residues[1][(0, 1)] = Complex::new(f64::NAN, 0.0);
        let p = passivity(&m, 2.0, 100);
        assert_eq!(p.violations, p.points);
        assert!(p.max_singular_value.is_infinite());
    }
}
