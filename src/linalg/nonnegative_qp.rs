//! A convex quadratic programme over the non-negative orthant, by an active set.

use crate::error::{FdidError, Result};
use nalgebra::{DMatrix, DVector};

/// Solves
///
/// ```text
/// min_λ ½ λᵀMλ + dᵀλ   subject to   λ ≥ 0
/// ```
///
/// for a symmetric positive semi-definite `m`, by the active-set method of Lawson and
/// Hanson written for the quadratic form: the free set P grows by the index of the most
/// negative gradient g = Mλ + d, the free variables solve M_PP λ_P = −d_P (Cholesky with
/// a ridge of 10⁻¹² of M's mean diagonal), and a free variable that would turn negative
/// is moved back to its bound. At the solution g ≥ 0 with g_i = 0 where λ_i > 0 (the
/// Karush–Kuhn–Tucker conditions). It is the dual of a least-norm problem with linear
/// inequalities, min ½xᵀHx subject to Cx ≤ d, with M = CH⁻¹Cᵀ and x = −H⁻¹Cᵀλ.
///
/// # Errors
/// [`FdidError::InvalidArgument`] for a non-square `m`, a `d` of another length or a
/// non-finite value; [`FdidError::NotConverged`] when the active set cycles beyond
/// 3n + 10 changes.
pub(crate) fn nonnegative_qp(m: &DMatrix<f64>, d: &DVector<f64>) -> Result<DVector<f64>> {
    let n = d.len();
    if m.nrows() != n || m.ncols() != n {
        return Err(FdidError::InvalidArgument {
            name: "m",
            value: format!("{} × {}", m.nrows(), m.ncols()),
            reason: format!("the quadratic form is square, of the {n} bounds' size"),
        });
    }
    crate::error::check_finite("m", m.as_slice())?;
    crate::error::check_finite("d", d.as_slice())?;
    let mut lambda = DVector::<f64>::zeros(n);
    if n == 0 {
        return Ok(lambda);
    }
    let ridge = 1e-12 * (m.trace() / n as f64).max(f64::MIN_POSITIVE);
    let scale = d.amax().max(f64::MIN_POSITIVE);
    let tolerance = 1e-12 * scale;
    let mut free = vec![false; n];
    let limit = 3 * n + 10;
    let mut changes = 0;
    loop {
        let gradient = m * &lambda + d;
        let entering = (0..n)
            .filter(|i| !free[*i] && gradient[*i] < -tolerance)
            .min_by(|a, b| gradient[*a].total_cmp(&gradient[*b]));
        let Some(j) = entering else {
            return Ok(lambda);
        };
        free[j] = true;
        loop {
            changes += 1;
            if changes > limit {
                return Err(FdidError::NotConverged {
                    method: "the non-negative quadratic programme",
                    reason: format!("the active set changed {limit} times"),
                });
            }
            let z = free_solution(m, d, &free, ridge);
            let Some(z) = z else {
                // a singular free block: the entering index adds nothing
                free[j] = false;
                return Ok(lambda);
            };
            if (0..n).all(|i| !free[i] || z[i] > 0.0) {
                lambda = z;
                break;
            }
            // the largest step from λ towards z that keeps every free variable ≥ 0
            let alpha = (0..n)
                .filter(|i| free[*i] && z[*i] <= 0.0)
                .map(|i| lambda[i] / (lambda[i] - z[i]))
                .fold(1.0, f64::min);
            lambda += (z - &lambda) * alpha;
            for i in 0..n {
                if free[i] && lambda[i] <= 1e-15 * scale {
                    free[i] = false;
                    lambda[i] = 0.0;
                }
            }
        }
    }
}

/// The solution of M_PP z_P = −d_P over the free set P (zero elsewhere), or `None` when
/// the block is singular.
fn free_solution(
    m: &DMatrix<f64>,
    d: &DVector<f64>,
    free: &[bool],
    ridge: f64,
) -> Option<DVector<f64>> {
    let index: Vec<usize> = (0..free.len()).filter(|i| free[*i]).collect();
    let k = index.len();
    let mut block = DMatrix::<f64>::from_fn(k, k, |r, c| m[(index[r], index[c])]);
    for r in 0..k {
        block[(r, r)] += ridge;
    }
    let rhs = DVector::<f64>::from_fn(k, |r, _| -d[index[r]]);
    let solved = block.cholesky()?.solve(&rhs);
    if solved.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mut z = DVector::<f64>::zeros(free.len());
    for (r, i) in index.iter().enumerate() {
        z[*i] = solved[r];
    }
    Some(z)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Random problems with a nearly singular M (rank 4 of 6 plus 10⁻³·I): the
    /// Karush–Kuhn–Tucker conditions hold (λ ≥ 0, g ≥ 0, g = 0 where λ > 0), which for a
    /// convex programme is the optimum.
    #[test]
    fn matches_the_kkt_conditions_on_random_problems() {
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for _ in 0..200 {
            let (n, rank) = (6, 4);
            let c = DMatrix::<f64>::from_fn(n, rank, |_, _| next());
            let m = &c * c.transpose() + DMatrix::identity(n, n) * 1e-3;
            let d = DVector::<f64>::from_fn(n, |_, _| next());
            let lambda = nonnegative_qp(&m, &d).unwrap();
            let g = &m * &lambda + &d;
            // the ridge (10⁻¹² of the mean diagonal) moves the gradient by about that
            // times λ
            let slack = 1e-9 * (1.0 + lambda.amax() * m.amax());
            for i in 0..n {
                assert!(lambda[i] >= 0.0);
                assert!(g[i] >= -slack, "gradient {g}");
                if lambda[i] > 0.0 {
                    assert!(g[i].abs() < slack, "gradient {g} at λ {lambda}");
                }
            }
        }
    }

    #[test]
    fn rejects_bad_shapes_and_values() {
        let m = DMatrix::<f64>::identity(2, 2);
        assert!(nonnegative_qp(&m, &DVector::from_vec(vec![1.0])).is_err());
        assert!(nonnegative_qp(&m, &DVector::from_vec(vec![1.0, f64::NAN])).is_err());
        let lambda = nonnegative_qp(&m, &DVector::from_vec(vec![-1.0, 2.0])).unwrap();
        assert!(
            (lambda[0] - 1.0).abs() < 1e-9 && lambda[1] == 0.0,
            "{lambda}"
        );
    }
}
