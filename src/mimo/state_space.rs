//! A real state-space realisation of a common-pole model.

use super::model::CommonPoleModel;
use crate::error::{FdidError, Result};
use crate::model::Domain;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;

/// A real state-space model ẋ = Ax + Bu, y = Cx + Du (or x_{k+1} = Ax_k + Bu_k in z).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct StateSpace<T: Real> {
    /// Continuous or discrete time.
    pub domain: Domain<T>,
    /// State matrix (n·nu × n·nu).
    pub a: DMatrix<T>,
    /// Input matrix (n·nu × nu).
    pub b: DMatrix<T>,
    /// Output matrix (ny × n·nu).
    pub c: DMatrix<T>,
    /// Direct term (ny × nu).
    pub d: DMatrix<T>,
}

impl<T: Real> CommonPoleModel<T> {
    /// The real realisation of Gilbert's form with each pole repeated nu times: for a real
    /// pole p with residue R, A ∋ pI, B ∋ I, C ∋ R; for a pair a ± iβ with residue R,
    ///
    /// ```text
    /// A ∋ [[aI, βI], [−βI, aI]],   B ∋ [2I; 0],   C ∋ [Re R, Im R],
    /// ```
    ///
    /// so that C(xI − A)⁻¹B + D = G(x) exactly, with n·nu states (vector fitting's
    /// realisation; a minimal one would use the ranks of the residues).
    pub fn state_space(&self) -> StateSpace<T> {
        let (ny, nu) = (self.ny(), self.nu());
        let states = self.order() * nu;
        let mut a = DMatrix::zeros(states, states);
        let mut b = DMatrix::zeros(states, nu);
        let mut c = DMatrix::zeros(ny, states);
        let nr = self.poles.real.len();
        let mut at = 0;
        for (m, r) in self.residues.iter().enumerate() {
            if m < nr {
                let p = self.poles.real[m];
                for j in 0..nu {
                    a[(at + j, at + j)] = p;
                    b[(at + j, j)] = T::one();
                    for i in 0..ny {
                        c[(i, at + j)] = r[(i, j)].re;
                    }
                }
                at += nu;
            } else {
                let p = self.poles.pairs[m - nr];
                for j in 0..nu {
                    a[(at + j, at + j)] = p.re;
                    a[(at + j, at + nu + j)] = p.im;
                    a[(at + nu + j, at + j)] = -p.im;
                    a[(at + nu + j, at + nu + j)] = p.re;
                    b[(at + j, j)] = T::lit(2.0);
                    for i in 0..ny {
                        c[(i, at + j)] = r[(i, j)].re;
                        c[(i, at + nu + j)] = r[(i, j)].im;
                    }
                }
                at += 2 * nu;
            }
        }
        StateSpace {
            domain: self.domain,
            a,
            b,
            c,
            d: self
                .direct
                .clone()
                .unwrap_or_else(|| DMatrix::zeros(ny, nu)),
        }
    }
}

impl<T: Real> StateSpace<T> {
    /// C(xI − A)⁻¹B + D at x = iω (s) or e^{iωTs} (z), one ny × nu matrix per line.
    ///
    /// # Errors
    /// A line at an eigenvalue of A (singular xI − A).
    pub fn response(&self, omega: &[T]) -> Result<Vec<DMatrix<Complex<T>>>> {
        let n = self.a.nrows();
        let a = self.a.map(|v| Complex::new(v, T::zero()));
        let b = self.b.map(|v| Complex::new(v, T::zero()));
        let c = self.c.map(|v| Complex::new(v, T::zero()));
        let d = self.d.map(|v| Complex::new(v, T::zero()));
        super::poles::points(omega, self.domain, T::one())
            .into_iter()
            .map(|x| {
                let m = DMatrix::<Complex<T>>::identity(n, n) * x - &a;
                let sol = m.lu().solve(&b).ok_or(FdidError::Singular {
                    what: "xI − A at a line of the state-space response",
                    condition: f64::INFINITY,
                })?;
                Ok(&c * sol + &d)
            })
            .collect()
    }
}
