//! The common-denominator (matrix-fraction) form of a common-pole model: one monic
//! denominator polynomial shared by every entry and one numerator polynomial per entry.

use super::model::CommonPoleModel;
use crate::model::Domain;
use crate::scalar::{Complex, Real};

/// G(x) = N(x)/a(x) with the monic common denominator a(x) = Π_m (x − p_m) of degree n
/// and one numerator N_ij(x) = D_ij a(x) + Σ_m R_m,ij Π_{l≠m}(x − p_l) per entry, both
/// real, as coefficients in **descending** powers of x:
///
/// ```text
/// a = [1, a_1, …, a_n],   N_ij = [b_0, b_1, …, b_n]   (b_0 = D_ij),
/// ```
///
/// so that in z, dividing by zⁿ, G_ij(z) = (b_0 + b_1 z⁻¹ + … + b_n z⁻ⁿ)/(1 + a_1 z⁻¹ +
/// … + a_n z⁻ⁿ) — the left matrix-fraction form A(z⁻¹)⁻¹B(z⁻¹) with the scalar A = a·I
/// (McKelvey's polynomial model per entry with the denominator shared) — and in s,
/// G_ij(s) = (b_0 sⁿ + … + b_n)/(sⁿ + a_1 sⁿ⁻¹ + … + a_n). Polynomial coefficients are
/// ill-conditioned for high orders (they amplify rounding as the poles cluster): the
/// partial fractions of [`CommonPoleModel`] are the form to compute with, this one the
/// form to hand to tools that take transfer-function coefficients.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct MatrixFraction<T: Real> {
    /// s or z.
    pub domain: Domain<T>,
    /// The monic denominator [1, a_1, …, a_n].
    pub denominator: Vec<T>,
    /// One numerator per entry, column by column ((1,1), (2,1), …), each n + 1
    /// coefficients.
    pub numerators: Vec<Vec<T>>,
    /// Outputs ny.
    pub ny: usize,
    /// Inputs nu.
    pub nu: usize,
}

impl<T: Real> MatrixFraction<T> {
    /// True when every coefficient is finite. The coefficients grow as products of the
    /// poles: in s, high orders with poles far from 1 rad/s overflow (order 50 with
    /// poles near 10¹⁰ rad/s reaches 10³⁰⁸), and the form is then not representable.
    pub fn is_finite(&self) -> bool {
        self.denominator
            .iter()
            .chain(self.numerators.iter().flatten())
            .all(|v| v.is_finite())
    }
}

impl<T: Real> CommonPoleModel<T> {
    /// The common-denominator form of the model ([`MatrixFraction`]).
    ///
    /// ```
    /// use fdid::mimo::{CommonPoleModel, PoleSet};
    /// use fdid::prelude::*;
    /// use nalgebra::DMatrix;
    ///
    /// // G(z) = 2/(z − 0.5): denominator z − 0.5, numerator 2 (b_0 = 0, b_1 = 2)
    /// let model = CommonPoleModel {
    ///     domain: Domain::Discrete { ts: 1.0 },
    ///     poles: PoleSet { real: vec![0.5], pairs: vec![] },
    ///     residues: vec![DMatrix::from_element(1, 1, Complex::new(2.0, 0.0))],
    ///     direct: None,
    /// };
    /// let mf = model.matrix_fraction();
    /// assert_eq!(mf.denominator, vec![1.0, -0.5]);
    /// assert_eq!(mf.numerators[0], vec![0.0, 2.0]);
    /// ```
    pub fn matrix_fraction(&self) -> MatrixFraction<T> {
        let nr = self.poles.real.len();
        // the real factors: x − p for a real pole, x² − 2 Re p x + |p|² for a pair
        let factors: Vec<Vec<T>> = self
            .poles
            .real
            .iter()
            .map(|p| vec![T::one(), -*p])
            .chain(
                self.poles
                    .pairs
                    .iter()
                    .map(|p| vec![T::one(), -(p.re + p.re), p.norm_sqr()]),
            )
            .collect();
        let product = |skip: Option<usize>| -> Vec<T> {
            factors
                .iter()
                .enumerate()
                .filter(|(m, _)| Some(*m) != skip)
                .fold(vec![T::one()], |acc, (_, f)| multiply(&acc, f))
        };
        let denominator = product(None);
        let n = denominator.len() - 1;
        let others: Vec<Vec<T>> = (0..factors.len()).map(|m| product(Some(m))).collect();
        let (ny, nu) = (self.ny(), self.nu());
        let mut numerators = Vec::with_capacity(ny * nu);
        for e in 0..ny * nu {
            let (i, j) = (e % ny, e / ny);
            let mut b = vec![T::zero(); n + 1];
            if let Some(d) = &self.direct {
                for (bk, ak) in b.iter_mut().zip(&denominator) {
                    *bk += d[(i, j)] * *ak;
                }
            }
            for (m, rest) in others.iter().enumerate() {
                let r: Complex<T> = self.residues[m][(i, j)];
                // R/(x − p) (+ R̄/(x − p̄) = (2 Re R x − 2 Re(R p̄))/(x² − 2 Re p x + |p|²))
                let top = if m < nr {
                    vec![r.re]
                } else {
                    let p = self.poles.pairs[m - nr];
                    vec![r.re + r.re, -((r * p.conj()).re * T::lit(2.0))]
                };
                let term = multiply(&top, rest);
                let offset = b.len() - term.len();
                for (k, t) in term.iter().enumerate() {
                    b[offset + k] += *t;
                }
            }
            numerators.push(b);
        }
        MatrixFraction {
            domain: self.domain,
            denominator,
            numerators,
            ny,
            nu,
        }
    }
}

impl<T: Real> MatrixFraction<T> {
    /// Entry (i, j)'s response N_ij(x)/a(x) at `omega` (rad/s), x = iω or e^{iωTs}.
    ///
    /// # Panics
    /// When i ≥ ny or j ≥ nu.
    pub fn response(&self, i: usize, j: usize, omega: &[T]) -> Vec<Complex<T>> {
        assert!(i < self.ny && j < self.nu, "entry ({i}, {j}) out of range");
        let num = &self.numerators[j * self.ny + i];
        super::poles::points(omega, self.domain, T::one())
            .into_iter()
            .map(|x| horner(num, x) / horner(&self.denominator, x))
            .collect()
    }
}

/// The product of two polynomials in descending powers.
fn multiply<T: Real>(a: &[T], b: &[T]) -> Vec<T> {
    let mut c = vec![T::zero(); a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            c[i + j] += *x * *y;
        }
    }
    c
}

/// A polynomial in descending powers at x.
fn horner<T: Real>(c: &[T], x: Complex<T>) -> Complex<T> {
    c.iter()
        .fold(Complex::new(T::zero(), T::zero()), |s, v| s * x + *v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mimo::PoleSet;
    use nalgebra::DMatrix;

    /// `pairs` lightly damped pairs spread over [w, 10 w] rad/s, unit residues.
    fn model(pairs: usize, w: f64) -> CommonPoleModel<f64> {
        let poles: Vec<Complex<f64>> = (0..pairs)
            .map(|m| {
                let wm = w * (1.0 + 9.0 * m as f64 / pairs as f64);
                Complex::new(-0.01 * wm, wm)
            })
            .collect();
        CommonPoleModel {
            domain: Domain::Continuous,
            residues: vec![DMatrix::from_element(1, 1, Complex::new(1.0, 0.5)); pairs],
            poles: PoleSet {
                real: vec![],
                pairs: poles,
            },
            direct: None,
        }
    }

    #[test]
    fn coefficients_that_overflow_are_reported() {
        // order 6 near 1 rad/s: representable; order 50 near 10¹⁰ rad/s: |p|⁵⁰ ≫ 10³⁰⁸
        assert!(model(3, 1.0).matrix_fraction().is_finite());
        assert!(!model(25, 1e10).matrix_fraction().is_finite());
    }
}
