//! Likelihood-ratio tests between nested fits (McKelvey §5, the ML cost of eq. 23 at its
//! minimum is ½χ²(2N − p) for a correct model with known noise).
//!
//! - Known noise (λ = 1): 2(V₀ − V₁) ~ χ²(p₁ − p₀) under the smaller model.
//! - Estimated noise: F = ((V₀ − V₁)/(p₁ − p₀)) / (V₁/(2N − p₁)) ~ F(p₁ − p₀, 2N − p₁).
//! - Different noise models (concentrated likelihood, eq. 26): N(W₀ − W₁) with W the
//!   log of the concentrated cost, ~ χ² on the extra parameters.
use crate::stats::chi2_sf;

/// The regularised incomplete beta function I_x(a, b) (a, b > 0, 0 ≤ x ≤ 1):
/// [`crate::stats::beta_reg`]. NaN for invalid input.
///
/// ```
/// let v = fdid::workflow::lrt::beta_inc(2.0, 3.0, 0.4);
/// assert!((v - 0.5248).abs() < 1e-12);
/// ```
pub fn beta_inc(a: f64, b: f64, x: f64) -> f64 {
    crate::stats::beta_reg(a, b, x)
}

/// P(X > f) for X ~ F(d1, d2): I_{d2/(d2 + d1 f)}(d2/2, d1/2). 1 for f ≤ 0; NaN for
/// non-positive degrees of freedom.
///
/// ```
/// // the 95 % point of F(1, 10) is 4.9646
/// let p = fdid::workflow::lrt::f_sf(4.964_602_743_730_7, 1.0, 10.0);
/// assert!((p - 0.05).abs() < 1e-9);
/// ```
pub fn f_sf(f: f64, d1: f64, d2: f64) -> f64 {
    crate::stats::f_sf(f, d1, d2)
}

/// Result of a likelihood-ratio test between a smaller fit (0) and a larger one (1).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct LrTest {
    /// The test statistic: 2(V₀ − V₁) (χ²) or F.
    pub statistic: f64,
    /// Degrees of freedom of the numerator, p₁ − p₀.
    pub dof: usize,
    /// The upper-tail probability under the smaller model.
    pub p_value: f64,
}

/// The likelihood-ratio test of a nested pair of output-error fits on the same N lines:
/// costs V₀ ≥ V₁ with p₀ < p₁ parameters. `noise_known`: the residuals are normalised by
/// the true noise level, so 2(V₀ − V₁) ~ χ²(p₁ − p₀); otherwise the F-test
/// F = ((V₀ − V₁)/(p₁ − p₀)) / (V₁/(2N − p₁)) ~ F(p₁ − p₀, 2N − p₁) (cost of eq. 23).
///
/// # Errors
/// [`crate::FdidError::InvalidArgument`] naming the value when p₁ ≤ p₀, 2N ≤ p₁, or a cost
/// is negative or not finite.
pub fn lr_test(
    v0: f64,
    p0: usize,
    v1: f64,
    p1: usize,
    n_lines: usize,
    noise_known: bool,
) -> crate::error::Result<LrTest> {
    if p1 <= p0 {
        return Err(crate::error::FdidError::InvalidArgument {
            name: "p1",
            value: p1.to_string(),
            reason: format!("the larger model needs more parameters than p0 = {p0}"),
        });
    }
    if 2 * n_lines <= p1 {
        return Err(crate::error::FdidError::InvalidArgument {
            name: "n_lines",
            value: n_lines.to_string(),
            reason: format!("2N must exceed p1 = {p1}"),
        });
    }
    for (name, v) in [("v0", v0), ("v1", v1)] {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(crate::error::FdidError::InvalidArgument {
                name,
                value: v.to_string(),
                reason: "a cost is finite and non-negative".into(),
            });
        }
    }
    let dof = p1 - p0;
    let drop = (v0 - v1).max(0.0);
    Ok(if noise_known {
        let statistic = 2.0 * drop;
        LrTest {
            statistic,
            dof,
            p_value: chi2_sf(statistic, dof as f64),
        }
    } else {
        let d2 = (2 * n_lines - p1) as f64;
        let statistic = if v1 > 0.0 {
            (drop / dof as f64) / (v1 / d2)
        } else {
            f64::INFINITY
        };
        let p_value = if statistic.is_finite() {
            f_sf(statistic, dof as f64, d2)
        } else {
            0.0
        };
        LrTest {
            statistic,
            dof,
            p_value,
        }
    })
}

/// The likelihood-ratio test between fits with different noise models (concentrated ML,
/// McKelvey eq. 26): N(W₀ − W₁) ~ ½χ²(extra) with W = ln of the concentrated cost per
/// line, i.e. statistic 2N(W₀ − W₁) ~ χ²(p₁ − p₀) on the N complex lines.
///
/// # Errors
/// As [`lr_test`].
pub fn concentrated_lr_test(
    w0: f64,
    p0: usize,
    w1: f64,
    p1: usize,
    n_lines: usize,
) -> crate::error::Result<LrTest> {
    if p1 <= p0 {
        return Err(crate::error::FdidError::InvalidArgument {
            name: "p1",
            value: p1.to_string(),
            reason: format!("the larger model needs more parameters than p0 = {p0}"),
        });
    }
    if !(w0.is_finite() && w1.is_finite()) {
        return Err(crate::error::FdidError::InvalidArgument {
            name: "w",
            value: format!("{w0}, {w1}"),
            reason: "the concentrated costs must be finite".into(),
        });
    }
    let dof = p1 - p0;
    let statistic = 2.0 * n_lines as f64 * (w0 - w1).max(0.0);
    Ok(LrTest {
        statistic,
        dof,
        p_value: chi2_sf(statistic, dof as f64),
    })
}
