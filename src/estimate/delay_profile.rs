//! The τ-profile of Levy's equation-error cost in a fixed basis: the delay search's first
//! candidate, at the cost of about one Gram matrix per delay.

use crate::data::FrequencyData;
use crate::linalg::gram::gram_into;
use crate::linalg::stack_rows;
use crate::model::EquationError;
use crate::model::delay::delay_factor;
use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DVector};
use num_traits::Float;

/// Delays between two exact phasors e^{iω_kτ_m}: the ones between are stepped by
/// e^{iω_kΔ}, whose rounding then grows over at most this many steps.
const EXACT_EVERY: usize = 64;

/// Levy's cost of `model`'s equation error at the delays τ_m = `start` + m·`step`,
/// m = 0 … `count` − 1:
///
/// ```text
/// V_L(τ) = min_{c, c_n = 1} Σ_k w_k² |R_k(τ) c|²        (McKelvey eq. 39)
/// ```
///
/// with R(τ) the regressor of [`EquationError::regressor_into`] on the data with τ
/// removed (Y_k e^{iω_kτ}, [`crate::model::remove_delay`]), c_n the normalising
/// coefficient and w_k the line weights (1 when `weights` is `None`). In a partial-fraction
/// basis relocated to a fit's poles, R_k c = (A Y_k − B U_k)/Π(iω_k − p_j) is the
/// Sanathanan–Koerner residual (eq. 41) weighted by the last poles.
///
/// **Method.** The regressor is affine in Y: R(τ) = S + D_τ R_Y, with S = R(0, U) (the
/// input's and the transient's columns), R_Y = R(Y, U) − S and D_τ = diag(e^{iω_kτ}). For
/// real c, |R_k c|² = cᵀ Re(R_kᴴR_k) c, so the Gram matrix is
///
/// ```text
/// G(τ) = Re(SᴴWS + R_YᴴWR_Y) + Re(X(τ)) + Re(X(τ))ᵀ,   X_ij(τ) = Σ_k w_k² conj(S_ki) R_Y,kj e^{iω_kτ}
/// ```
///
/// whose first term is formed once and whose X is nonzero only between the columns S
/// and R_Y fill. One pass over the lines accumulates Re X for every τ_m, the phasor
/// stepped by e^{iω_kΔ} (exact every 64 delays). Each V_L(τ_m) then solves the normal
/// equations G_oo c_o = −g_on of the coefficients other than the normalising one,
/// equilibrated to a unit diagonal and factored by Cholesky (with a ridge of √ε on the
/// unit diagonal when that fails: an over-parameterised model on noise-free data leaves G
/// singular at the right delay), and evaluates cᵀGc. The profile only ranks delays, so
/// the squared condition of the normal equations does not reach a result (see
/// [`crate::linalg::gram`]).
///
/// Cost: two regressors, N·|S|·|R_Y| products and N·count·|S|·|R_Y| multiply–adds, where
/// a screening fit costs several Gram matrices of N·q² each. Delays whose solve fails
/// get an infinite cost.
pub(super) fn levy_profile<T: Real, M: EquationError<T> + ?Sized>(
    model: &M,
    data: &FrequencyData<T>,
    weights: Option<&[T]>,
    start: T,
    step: T,
    count: usize,
) -> Vec<T> {
    let (n, q) = (data.len(), model.n_coefficients());
    let mut ry = DMatrix::zeros(n, q);
    model.regressor_into(data, &mut ry);
    let zero = Complex::new(T::zero(), T::zero());
    let no_output = FrequencyData::from_parts_unchecked(
        data.omega().to_vec(),
        vec![zero; n],
        data.u().to_vec(),
        None,
        data.ts(),
    );
    let mut s = DMatrix::zeros(n, q);
    model.regressor_into(&no_output, &mut s);
    ry -= &s;
    if let Some(w) = weights {
        for (k, wk) in w.iter().enumerate() {
            ry.row_mut(k).scale_mut(*wk);
            s.row_mut(k).scale_mut(*wk);
        }
    }
    let filled = |m: &DMatrix<Complex<T>>| -> Vec<usize> {
        (0..q)
            .filter(|j| m.column(*j).iter().any(|v| v.norm_sqr() > T::zero()))
            .collect()
    };
    let (cs, cy) = (filled(&s), filled(&ry));
    let mut fixed = DMatrix::zeros(q, q);
    gram_into(&stack_rows(&s, None), &mut fixed, false);
    gram_into(&stack_rows(&ry, None), &mut fixed, true);
    let cross = cross_terms(&s, &ry, &cs, &cy, data.omega(), start, step, count);
    let normalising = model.normalising_index();
    (0..count)
        .map(|m| {
            let mut g = fixed.clone();
            for (a, i) in cs.iter().enumerate() {
                for (b, j) in cy.iter().enumerate() {
                    let v = cross[(a * cy.len() + b) * count + m];
                    g[(*i, *j)] += v;
                    g[(*j, *i)] += v;
                }
            }
            normalised_cost(&g, normalising).unwrap_or_else(T::infinity)
        })
        .collect()
}

/// The local minima of `cost` whose value is at most `within` times the lowest, lowest
/// first, at most `most` of them, each in units of the index: between indices by the
/// vertex of the parabola through the logarithms of the minimum and its two neighbours
/// (moved by at most half an index; not at the ends, nor where the parabola does not open
/// upwards). Non-finite values are never minima; empty when no value is finite.
pub(super) fn profile_minima<T: Real>(cost: &[T], within: T, most: usize) -> Vec<T> {
    let n = cost.len();
    let finite = |i: usize| Float::is_finite(cost[i]);
    // a finite value no higher than its finite neighbours (a non-finite neighbour is higher)
    let below = |i: usize, j: usize| !finite(j) || cost[i] <= cost[j];
    let mut minima: Vec<usize> = (0..n)
        .filter(|i| finite(*i) && (*i == 0 || below(*i, i - 1)) && (i + 1 == n || below(*i, i + 1)))
        .collect();
    // of a run of equal minima keep the first
    minima.dedup_by(|b, a| *b == *a + 1);
    minima.sort_by(|a, b| {
        cost[*a]
            .partial_cmp(&cost[*b])
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let Some(lowest) = minima.first().map(|m| cost[*m]) else {
        return vec![];
    };
    minima
        .into_iter()
        .take_while(|m| cost[*m] <= lowest * within)
        .take(most)
        .map(|m| T::from_usize_lossy(m) + vertex_offset(cost, m))
        .collect()
}

/// The vertex of the parabola through ln cost at `m` − 1, `m`, `m` + 1, relative to `m` and
/// within ±1/2; zero at the ends, at non-finite neighbours or where it does not open
/// upwards.
fn vertex_offset<T: Real>(cost: &[T], m: usize) -> T {
    if m == 0 || m + 1 >= cost.len() {
        return T::zero();
    }
    let [a, b, c] = [cost[m - 1], cost[m], cost[m + 1]]
        .map(|v| Float::ln(Float::max(v, T::min_positive_value())));
    let curvature = a - b * T::lit(2.0) + c;
    if !(curvature > T::zero() && Float::is_finite(curvature)) {
        return T::zero();
    }
    let half = T::lit(0.5);
    let offset = (a - c) / (curvature * T::lit(2.0));
    Float::max(Float::min(offset, half), -half)
}

/// Re X_ij(τ_m) = Re Σ_k conj(S_ki) R_Y,kj e^{iω_kτ_m} for i ∈ `cs`, j ∈ `cy` and
/// τ_m = `start` + m·`step`: |cs|·|cy| rows (row-major in (i, j)) of `count` values, so
/// that each line's update runs along the delays.
#[allow(clippy::too_many_arguments)]
fn cross_terms<T: Real>(
    s: &DMatrix<Complex<T>>,
    ry: &DMatrix<Complex<T>>,
    cs: &[usize],
    cy: &[usize],
    omega: &[T],
    start: T,
    step: T,
    count: usize,
) -> Vec<T> {
    let pairs = cs.len() * cy.len();
    let mut cross = vec![T::zero(); pairs * count];
    let (mut zre, mut zim) = (vec![T::zero(); count], vec![T::zero(); count]);
    for (k, w) in omega.iter().enumerate() {
        // e^{iωτ} is the conjugate of the delay factor e^{−iωτ}
        let turn = delay_factor(*w, step).conj();
        let mut z = Complex::new(T::one(), T::zero());
        for m in 0..count {
            if m.is_multiple_of(EXACT_EVERY) {
                z = delay_factor(*w, start + step * T::from_usize_lossy(m)).conj();
            }
            zre[m] = z.re;
            zim[m] = z.im;
            z *= turn;
        }
        let mut rows = cross.chunks_exact_mut(count);
        for i in cs {
            let si = s[(k, *i)].conj();
            for j in cy {
                let p = si * ry[(k, *j)];
                let row = rows.next().expect("one row per pair");
                for ((r, c), d) in row.iter_mut().zip(&zre).zip(&zim) {
                    *r += p.re * *c - p.im * *d;
                }
            }
        }
    }
    cross
}

/// min cᵀ`g`c over c with c_n = 1 (n = `normalising`), by the equilibrated normal
/// equations of the other coefficients, a ridge of √ε added when Cholesky fails; `None`
/// when the solve does not give a finite cost.
fn normalised_cost<T: Real>(g: &DMatrix<T>, normalising: usize) -> Option<T> {
    let q = g.nrows();
    let others: Vec<usize> = (0..q).filter(|j| *j != normalising).collect();
    let goo = DMatrix::from_fn(others.len(), others.len(), |a, b| g[(others[a], others[b])]);
    let gon = DVector::from_iterator(others.len(), others.iter().map(|i| g[(*i, normalising)]));
    let (d, mut gs) = crate::linalg::gram::equilibrated(&goo)?;
    let rhs = DVector::from_iterator(others.len(), gon.iter().zip(&d).map(|(v, d)| -*v / *d));
    let y = match gs.clone().cholesky() {
        Some(chol) => chol.solve(&rhs),
        None => {
            let ridge = Float::sqrt(T::default_epsilon());
            for j in 0..others.len() {
                gs[(j, j)] += ridge;
            }
            gs.cholesky()?.solve(&rhs)
        }
    };
    let mut c = DVector::zeros(q);
    c[normalising] = T::one();
    for ((i, v), d) in others.iter().zip(y.iter()).zip(&d) {
        c[*i] = *v / *d;
    }
    let cost = c.dot(&(g * &c));
    Float::is_finite(cost).then_some(Float::max(cost, T::zero()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Rational, remove_delay};

    /// A second-order continuous-time system delayed by `tau` on 200 lines.
    fn delayed(tau: f64) -> FrequencyData<f64> {
        let omega: Vec<f64> = (0..200).map(|k| 0.05 * (k + 1) as f64).collect();
        let frf = omega
            .iter()
            .map(|w| {
                let s = Complex::new(0.0, *w);
                (s * s + s * 0.3 + 4.0).inv() * (s + 2.0) * delay_factor(*w, tau)
            })
            .collect();
        FrequencyData::from_frf(omega, frf, None).unwrap()
    }

    #[test]
    fn profile_equals_levy_on_the_compensated_data() {
        let data = delayed(0.7);
        let model = Rational::continuous(2, 1, data.omega()).unwrap();
        let profile = levy_profile(&model, &data, None, 0.2, 0.1, 11);
        for (m, v) in profile.iter().enumerate() {
            let tau = 0.2 + 0.1 * m as f64;
            let compensated = remove_delay(&data, tau).unwrap();
            let system = crate::criterion::EquationErrorSystem::new(
                &model,
                &compensated,
                crate::data::NoiseWeighting::default(),
            )
            .unwrap();
            let (a, b) = system.normalised(None);
            let x = a.clone().svd(true, true).solve(&b, 1e-14).unwrap();
            let direct = (&a * &x - &b).norm_squared();
            assert!(
                (v - direct).abs() <= 1e-9 * (1.0 + direct),
                "τ {tau}: profile {v} against {direct}"
            );
        }
    }

    #[test]
    fn profile_minima_are_placed_between_delays_lowest_first() {
        // log V = (m − 2.3)²: the vertex at 2.3
        let cost: Vec<f64> = (0..6).map(|m| ((m as f64 - 2.3).powi(2)).exp()).collect();
        let minima = profile_minima(&cost, 2.0, 3);
        assert_eq!(minima.len(), 1);
        assert!((minima[0] - 2.3).abs() < 1e-12);
        // two minima, the second within the factor, a third beyond it
        let cost = [5.0, 1.0, 4.0, 1.5, 6.0, 9.0, 3.5, 8.0];
        assert_eq!(profile_minima(&cost, 2.0, 3).len(), 2);
        assert_eq!(profile_minima(&cost, 4.0, 3).len(), 3);
        assert_eq!(profile_minima(&cost, 4.0, 1).len(), 1);
        let m = profile_minima(&cost, 2.0, 3);
        assert!(
            (m[0] - 1.0).abs() <= 0.5 && (m[1] - 3.0).abs() <= 0.5,
            "{m:?}"
        );
        // non-finite values are never minima and never stop one
        assert_eq!(
            profile_minima(&[3.0, 1.0, f64::INFINITY], 1.0, 3),
            vec![1.0]
        );
        assert_eq!(profile_minima(&[f64::NAN, 2.0, 5.0], 1.0, 3), vec![1.0]);
        assert!(profile_minima::<f64>(&[f64::INFINITY, f64::NAN], 2.0, 3).is_empty());
        assert!(profile_minima::<f64>(&[], 2.0, 3).is_empty());
        // a plateau is one minimum
        assert_eq!(profile_minima(&[3.0, 1.0, 1.0, 3.0], 2.0, 3).len(), 1);
    }

    #[test]
    fn profile_is_lowest_at_the_delay() {
        let data = delayed(0.7);
        let model = Rational::continuous(2, 1, data.omega()).unwrap();
        let profile = levy_profile(&model, &data, None, 0.0, 0.05, 41);
        let lowest = (0..profile.len())
            .min_by(|a, b| profile[*a].total_cmp(&profile[*b]))
            .unwrap();
        assert_eq!(lowest, 14, "profile {profile:?}");
        assert!(profile[14] < 1e-12 * profile[0]);
    }
}
