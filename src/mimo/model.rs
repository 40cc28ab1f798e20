//! The common-pole model in partial-fraction form with residue matrices.

use super::poles::PoleSet;
use crate::error::{FdidError, Result};
use crate::model::Domain;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// A multi-input multi-output model with poles shared by every entry, in vector fitting's
/// multiport form:
///
/// ```text
/// G(x) = D + Σ_m R_m/(x − p_m),   x = s = iω (continuous) or z = e^{iωTs} (discrete),
/// ```
///
/// with one ny × nu residue matrix R_m per pole, R̄_m for the conjugate of a complex pole
/// (so G is real), and an optional real direct term D. Entry (i, j) is the scalar
/// partial-fraction model G_ij = D_ij + Σ (R_m)_ij/(x − p_m): every entry has the same
/// denominator Π(x − p_m), the common-denominator (matrix-fraction) form
/// G = N(x)/a(x) with a(x) = Π(x − p_m).
///
/// The residue matrices are stored per slot of [`PoleSet::slots`]: real poles first
/// (real residues), then the Im p > 0 member of each pair.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct CommonPoleModel<T: Real> {
    /// s (poles in rad/s) or z (poles in the z-plane, sample time ts).
    pub domain: Domain<T>,
    /// The shared poles.
    pub poles: PoleSet<T>,
    /// One ny × nu residue matrix per slot of [`PoleSet::slots`].
    pub residues: Vec<DMatrix<Complex<T>>>,
    /// The direct term D (ny × nu), when estimated.
    pub direct: Option<DMatrix<T>>,
}

/// One mode of a [`CommonPoleModel`]: its pole in s, natural frequency, damping, and the
/// rank-one approximation of its residue matrix R ≈ σ₁u₁v₁ᴴ.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Mode<T: Real> {
    /// The pole in s (rad/s); for a discrete-time model ln(p_z)/Ts.
    pub pole: Complex<T>,
    /// Natural frequency |p|/2π (Hz).
    pub f_n_hz: T,
    /// Damping ratio −Re p/|p|.
    pub damping: T,
    /// Output mode shape u₁ (length ny), scaled so its largest component is 1.
    pub shape: Vec<Complex<T>>,
    /// Input participation v₁ (length nu), scaled likewise.
    pub participation: Vec<Complex<T>>,
    /// σ₂/σ₁ of the residue matrix: 0 for an exactly rank-one residue (one mode shape).
    pub rank_one_error: T,
}

impl<T: Real> CommonPoleModel<T> {
    /// Outputs ny.
    pub fn ny(&self) -> usize {
        self.residues
            .first()
            .map(|r| r.nrows())
            .or(self.direct.as_ref().map(|d| d.nrows()))
            .unwrap_or(0)
    }

    /// Inputs nu.
    pub fn nu(&self) -> usize {
        self.residues
            .first()
            .map(|r| r.ncols())
            .or(self.direct.as_ref().map(|d| d.ncols()))
            .unwrap_or(0)
    }

    /// The order n (number of poles).
    pub fn order(&self) -> usize {
        self.poles.order()
    }

    /// G(iω) or G(e^{iωTs}) at each of `omega` (rad/s): one ny × nu matrix per line,
    /// D + Σ R_m/(x − p_m) (+ conj(R_m)/(x − conj p_m) for each complex pair).
    ///
    /// Each term is written with the real and imaginary parts of its residue matrix,
    /// R/(x − p) + conj(R)/(x − p̄) = Re R·(a + b) + Im R·i(a − b) with a = 1/(x − p),
    /// b = 1/(x − p̄) (a real pole: Re R·a + Im R·ia), so that G = D + B·C with B the
    /// complex basis (lines × 2 slots) and C the real residue parts (2 slots × entries):
    /// two real matrix products, for its real and imaginary parts.
    pub fn response(&self, omega: &[T]) -> Vec<DMatrix<Complex<T>>> {
        // lines per product: the bases of a chunk stay in cache
        const CHUNK: usize = 512;
        let x = super::poles::points(omega, self.domain, T::one());
        let slots = self.poles.slots();
        let nr = self.poles.real.len();
        let (ny, nu) = (self.ny(), self.nu());
        let i = Complex::new(T::zero(), T::one());
        let parts = DMatrix::from_fn(2 * slots.len(), ny * nu, |c, e| {
            let r = self.residues[c / 2][e];
            if c % 2 == 0 { r.re } else { r.im }
        });
        let chunk = |x: &[Complex<T>]| {
            let mut re = DMatrix::<T>::zeros(x.len(), 2 * slots.len());
            let mut im = DMatrix::<T>::zeros(x.len(), 2 * slots.len());
            for (m, p) in slots.iter().enumerate() {
                for (k, xk) in x.iter().enumerate() {
                    let a = crate::scalar::recip(*xk - *p);
                    let (even, odd) = if m < nr {
                        (a, i * a)
                    } else {
                        let b = crate::scalar::recip(*xk - p.conj());
                        (a + b, i * (a - b))
                    };
                    re[(k, 2 * m)] = even.re;
                    im[(k, 2 * m)] = even.im;
                    re[(k, 2 * m + 1)] = odd.re;
                    im[(k, 2 * m + 1)] = odd.im;
                }
            }
            let (re, im) = (re * &parts, im * &parts);
            (0..x.len())
                .map(|k| {
                    DMatrix::from_fn(ny, nu, |a, b| {
                        let e = a + b * ny;
                        let d = self.direct.as_ref().map_or(T::zero(), |d| d[(a, b)]);
                        Complex::new(d + re[(k, e)], im[(k, e)])
                    })
                })
                .collect::<Vec<_>>()
        };
        crate::linalg::parallel::map_indices(x.len().div_ceil(CHUNK), |c| {
            chunk(&x[c * CHUNK..x.len().min((c + 1) * CHUNK)])
        })
        .into_iter()
        .flatten()
        .collect()
    }

    /// The response of entry (i, j) at `omega` (rad/s).
    pub fn entry_response(&self, i: usize, j: usize, omega: &[T]) -> Vec<Complex<T>> {
        self.response(omega).iter().map(|g| g[(i, j)]).collect()
    }

    /// The modes: each pole (one per pair) with its natural frequency, damping and mode
    /// shape, sorted by natural frequency.
    ///
    /// # Errors
    /// A pole on or beyond the origin of the z-plane (no continuous-time equivalent), a
    /// residue matrix whose SVD fails.
    pub fn modes(&self) -> Result<Vec<Mode<T>>> {
        let mut out = Vec::new();
        for (p, r) in self.poles.slots().iter().zip(&self.residues) {
            let s = match self.domain {
                Domain::Continuous => *p,
                Domain::Discrete { ts } => {
                    if p.norm() == T::zero() {
                        return Err(FdidError::InvalidArgument {
                            name: "pole",
                            value: "0".into(),
                            reason: "a pole at z = 0 has no continuous-time equivalent".into(),
                        });
                    }
                    p.ln() / ts
                }
            };
            let w = s.norm();
            let (shape, participation, rank_one_error) = rank_one(r);
            out.push(Mode {
                pole: s,
                f_n_hz: w / T::two_pi(),
                damping: if w > T::zero() { -s.re / w } else { T::one() },
                shape,
                participation,
                rank_one_error,
            });
        }
        out.sort_by(|a, b| {
            a.f_n_hz
                .partial_cmp(&b.f_n_hz)
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        Ok(out)
    }
}

/// The leading left and right singular vectors of a residue matrix (each scaled by
/// [`normalised`]) and σ₂/σ₁; empty vectors when the SVD does not converge.
fn rank_one<T: Real>(r: &DMatrix<Complex<T>>) -> (Vec<Complex<T>>, Vec<Complex<T>>, T) {
    let Some(svd) =
        nalgebra::SVD::try_new_unordered(r.clone(), true, true, T::default_epsilon(), 1000)
    else {
        return (Vec::new(), Vec::new(), T::zero());
    };
    let sv = &svd.singular_values;
    let mut order: Vec<usize> = (0..sv.len()).collect();
    order.sort_by(|a, b| {
        sv[*b]
            .partial_cmp(&sv[*a])
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let (Some(u), Some(vt), Some(&top)) = (&svd.u, &svd.v_t, order.first()) else {
        return (Vec::new(), Vec::new(), T::zero());
    };
    let ratio = match order.get(1) {
        Some(&second) if sv[top] > T::zero() => sv[second] / sv[top],
        _ => T::zero(),
    };
    (
        normalised(u.column(top).iter().copied().collect()),
        normalised(vt.row(top).iter().map(|v| v.conj()).collect()),
        ratio,
    )
}

/// A vector scaled so that its largest component is 1 (real).
fn normalised<T: Real>(v: Vec<Complex<T>>) -> Vec<Complex<T>> {
    let big = v
        .iter()
        .copied()
        .fold(Complex::new(T::zero(), T::zero()), |a, b| {
            if b.norm() > a.norm() { b } else { a }
        });
    if big.norm() == T::zero() {
        return v;
    }
    v.into_iter().map(|c| c / big).collect()
}

impl<T: Real> CommonPoleModel<T> {
    /// Checks the model (e.g. one read from a file): finite poles, one residue matrix per
    /// slot, every residue matrix (and the direct term) of one shape ny × nu with ny, nu
    /// ≥ 1, finite values, and a positive finite sample time in z.
    ///
    /// # Errors
    /// [`FdidError::LengthMismatch`] for the number or shape of the matrices,
    /// [`FdidError::InvalidArgument`] for no output or input or a bad sample time,
    /// [`FdidError::Numerical`] or `NonFinite` for values that are not finite.
    pub fn check(&self) -> Result<()> {
        self.poles.check_finite()?;
        if let Domain::Discrete { ts } = self.domain {
            crate::data::check_ts(ts)?;
        }
        let n = self.poles.real.len() + self.poles.pairs.len();
        if self.residues.len() != n {
            return Err(FdidError::LengthMismatch {
                what: "residue matrices",
                expected: n,
                got: self.residues.len(),
            });
        }
        let (ny, nu) = (self.ny(), self.nu());
        if ny == 0 || nu == 0 {
            return Err(FdidError::InvalidArgument {
                name: "residue matrices",
                value: format!("{ny} x {nu}"),
                reason: "a model has at least one output and one input".into(),
            });
        }
        let shapes = self
            .residues
            .iter()
            .map(|r| r.shape())
            .chain(self.direct.as_ref().map(|d| d.shape()));
        for shape in shapes {
            if shape != (ny, nu) {
                return Err(FdidError::LengthMismatch {
                    what: "entries of a residue or direct matrix (as the first one's)",
                    expected: ny * nu,
                    got: shape.0 * shape.1,
                });
            }
        }
        let finite = self.residues.iter().all(|r| {
            r.iter()
                .all(|v| Float::is_finite(v.re) && Float::is_finite(v.im))
        }) && self
            .direct
            .as_ref()
            .is_none_or(|d| d.iter().all(|v| Float::is_finite(*v)));
        if !finite {
            return Err(FdidError::Numerical {
                what: "residue matrices".into(),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// G at one point summed term by term, the definition.
    fn direct_sum(m: &CommonPoleModel<f64>, x: Complex<f64>) -> DMatrix<Complex<f64>> {
        let mut g = m.direct.as_ref().map_or_else(
            || DMatrix::zeros(m.ny(), m.nu()),
            |d| d.map(|v| Complex::new(v, 0.0)),
        );
        let nr = m.poles.real.len();
        for (k, (p, r)) in m.poles.slots().iter().zip(&m.residues).enumerate() {
            g += r / (x - p);
            if k >= nr {
                g += r.map(|v| v.conj()) / (x - p.conj());
            }
        }
        g
    }

    #[test]
    fn response_is_the_sum_of_its_terms_in_s_and_z() {
        for (domain, direct) in [
            (Domain::Continuous, true),
            (Domain::Discrete { ts: 0.1 }, false),
        ] {
            let (ny, nu) = (3, 2);
            let pairs = match domain {
                Domain::Continuous => vec![Complex::new(-0.1, 2.0), Complex::new(-0.3, 5.0)],
                Domain::Discrete { .. } => vec![Complex::new(0.8, 0.3), Complex::new(0.1, 0.9)],
            };
            let real = match domain {
                Domain::Continuous => vec![-1.0],
                Domain::Discrete { .. } => vec![0.5],
            };
            let residues = (0..3)
                .map(|m| {
                    DMatrix::from_fn(ny, nu, |i, j| {
                        let t = (m * 5 + i * 3 + j) as f64;
                        Complex::new(t.sin(), if m == 0 { 0.0 } else { t.cos() })
                    })
                })
                .collect();
            let m = CommonPoleModel {
                domain,
                poles: PoleSet { real, pairs },
                residues,
                direct: direct.then(|| DMatrix::from_fn(ny, nu, |i, j| (i + j) as f64)),
            };
            // more lines than one chunk of the products
            let omega: Vec<f64> = (0..1200).map(|k| 0.01 + k as f64 * 0.025).collect();
            let x = super::super::poles::points(&omega, domain, 1.0);
            for (g, xk) in m.response(&omega).iter().zip(&x) {
                let want = direct_sum(&m, *xk);
                let err = (g - &want).iter().map(|v| v.norm()).fold(0.0, f64::max);
                assert!(err < 1e-12 * want.iter().map(|v| v.norm()).fold(1.0, f64::max));
            }
        }
    }
}
