//! The crate's error type: every failure is a variant that names the offending value.

use thiserror::Error;

/// Errors returned by data validation, model construction, estimators and readers.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum FdidError {
    /// Two sequences that must have the same length do not.
    #[error("length mismatch: {what} has {got} entries, expected {expected}")]
    LengthMismatch {
        /// What was measured.
        what: &'static str,
        /// The required length.
        expected: usize,
        /// The length found.
        got: usize,
    },
    /// A value is NaN or infinite.
    #[error("{what}[{index}] is not finite ({value})")]
    NonFinite {
        /// Which sequence.
        what: &'static str,
        /// Index of the bad entry.
        index: usize,
        /// The value, as text (`NaN`, `inf`, …).
        value: String,
    },
    /// Too few samples or lines.
    #[error("{what}: {got} given, at least {needed} needed")]
    TooShort {
        /// What is too short.
        what: &'static str,
        /// What is needed.
        needed: usize,
        /// What was given.
        got: usize,
    },
    /// Frequencies are not in increasing order.
    #[error("frequencies must increase: entry {index} ({value}) follows {previous}")]
    Unsorted {
        /// Index of the first out-of-order entry.
        index: usize,
        /// Its value.
        value: f64,
        /// The value before it.
        previous: f64,
    },
    /// The same frequency appears twice where that is not allowed.
    #[error("duplicate frequency {value} at entry {index}")]
    DuplicateFrequency {
        /// Index of the second occurrence.
        index: usize,
        /// The repeated frequency.
        value: f64,
    },
    /// A frequency is negative.
    #[error("negative frequency {value} at entry {index}")]
    NegativeFrequency {
        /// Index of the bad entry.
        index: usize,
        /// The value.
        value: f64,
    },
    /// The data hold fewer real equations than the model has parameters.
    #[error(
        "too few frequencies for the model: {lines} lines give {equations} real equations for {parameters} parameters"
    )]
    TooFewFrequencies {
        /// Number of frequency lines.
        lines: usize,
        /// Number of real equations they give.
        equations: usize,
        /// Number of free parameters.
        parameters: usize,
    },
    /// A setting is out of its valid range.
    #[error("invalid {name} = {value}: {reason}")]
    InvalidArgument {
        /// Name of the setting.
        name: &'static str,
        /// Its value, as text.
        value: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A band selects no frequency lines.
    #[error(
        "the band {} .. {} Hz ({min} .. {max} rad/s) selects no frequency lines",
        hz(*min),
        hz(*max)
    )]
    EmptyBand {
        /// Lower edge (rad/s).
        min: f64,
        /// Upper edge (rad/s).
        max: f64,
    },
    /// The input spectrum is zero where data are used.
    #[error(
        "the input spectrum is zero at {} Hz (entry {index} of the lines used): that line carries no information on the system",
        hz(*omega)
    )]
    ZeroInput {
        /// Index of the line.
        index: usize,
        /// Its frequency.
        omega: f64,
    },
    /// The output is zero on every line: there is no response to fit.
    #[error(
        "the output is zero on all {lines} lines used: there is no response to fit (check the output column or signal)"
    )]
    ZeroOutput {
        /// Number of lines.
        lines: usize,
    },
    /// A linear problem is rank deficient or too ill-conditioned to solve.
    #[error("singular problem: {what} ({})", condition_text(*condition))]
    Singular {
        /// Which problem.
        what: &'static str,
        /// Estimated condition number (infinite when exactly singular).
        condition: f64,
    },
    /// An iterative method stopped without converging.
    #[error("{method} did not converge: {reason}")]
    NotConverged {
        /// The method.
        method: &'static str,
        /// Why it stopped.
        reason: String,
    },
    /// A numerical failure: the model produced non-finite values.
    #[error("numerical failure in {what}")]
    Numerical {
        /// Where it happened.
        what: String,
    },
    /// A data file could not be read.
    #[error("{path}: line {line}: {message}")]
    Parse {
        /// File name (or `<input>`).
        path: String,
        /// 1-based line number (0 for the header or the whole file).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// An I/O error, as text.
    #[error("{0}")]
    Io(String),
}

/// `Result` with [`FdidError`].
pub type Result<T> = std::result::Result<T, FdidError>;

/// True when any value is not finite: 0·x is 0 for finite x and NaN for ±∞ and NaN, and
/// the flags are or-ed without an early exit, so that the loop runs on vector lanes (a
/// search for the first bad value takes several times longer on clean data; `is_finite`
/// or-ed the same way measured slower).
pub(crate) fn any_non_finite<T: crate::scalar::Real>(values: impl Iterator<Item = T>) -> bool {
    values.fold(false, |bad, v| bad | (v * T::zero() != T::zero()))
}

/// Checks that every value is finite; names the first bad one.
pub(crate) fn check_finite<T: crate::scalar::Real>(what: &'static str, values: &[T]) -> Result<()> {
    if !any_non_finite(values.iter().copied()) {
        return Ok(());
    }
    match values
        .iter()
        .position(|v| !num_traits::Float::is_finite(*v))
    {
        None => Ok(()),
        Some(index) => Err(FdidError::NonFinite {
            what,
            index,
            value: format!("{}", values[index]),
        }),
    }
}

/// Checks that every complex value is finite; names the first bad one.
pub(crate) fn check_finite_complex<T: crate::scalar::Real>(
    what: &'static str,
    values: &[crate::scalar::Complex<T>],
) -> Result<()> {
    if !any_non_finite(values.iter().map(|v| v.re + v.im)) {
        return Ok(());
    }
    match values
        .iter()
        .position(|v| !(num_traits::Float::is_finite(v.re) && num_traits::Float::is_finite(v.im)))
    {
        None => Ok(()),
        Some(index) => Err(FdidError::NonFinite {
            what,
            index,
            value: format!("{}", values[index]),
        }),
    }
}

/// The condition number of a [`FdidError::Singular`] in words: a number, "exactly
/// singular" for ∞, or a note that the matrix holds values that are not finite.
fn condition_text(condition: f64) -> String {
    if condition.is_nan() {
        "the matrix holds values that are not finite".into()
    } else if condition.is_infinite() {
        "exactly singular".into()
    } else {
        format!("condition number {condition:.3e}")
    }
}

/// The frequency ω (rad/s) in Hz with 7 significant digits (trailing zeros dropped).
fn hz(omega: f64) -> String {
    let f = omega / std::f64::consts::TAU;
    if f == 0.0 || !f.is_finite() {
        return f.to_string();
    }
    let decimals = (6 - f.abs().log10().floor() as i64).clamp(0, 320) as usize;
    let text = format!("{f:.decimals$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scalar::Complex;

    #[test]
    fn finiteness_checks_name_the_first_bad_value_and_pass_large_finite_ones() {
        let mut v = vec![1.0f64; 37];
        assert!(check_finite("v", &v).is_ok());
        v[20] = f64::NEG_INFINITY;
        v[30] = f64::NAN;
        assert!(matches!(
            check_finite("v", &v),
            Err(FdidError::NonFinite { index: 20, .. })
        ));
        // re + im overflows, yet both parts are finite: not an error
        let big = Complex::new(f64::MAX, f64::MAX);
        let mut c = vec![big; 9];
        assert!(check_finite_complex("c", &c).is_ok());
        c[4] = Complex::new(0.0, f64::NAN);
        assert!(matches!(
            check_finite_complex("c", &c),
            Err(FdidError::NonFinite { index: 4, .. })
        ));
        assert!(!any_non_finite([0.0f32, -3.5, 1e30].into_iter()));
        assert!(any_non_finite([0.0f32, f32::INFINITY].into_iter()));
    }
}
