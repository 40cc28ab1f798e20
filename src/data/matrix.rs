//! Frequency response matrices: an ny × nu FRF per line, measured on one frequency grid,
//! with optional per-entry noise variances.

use super::{FrequencyData, InputNoise, NoiseVariances};
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DVector};
use num_traits::Float;

/// An ny × nu frequency response matrix G_k per line ω_k (rad/s): entry (i, j) is the
/// response of output i to input j. Entries are stored column by column — (1,1), (2,1), …,
/// (ny,1), (1,2), … — the order of a multi-channel CSV file (`f,re_11,im_11,re_21,im_21,…`)
/// and of 2-port Touchstone data. Each entry is a [`FrequencyData`] (U = 1, Y = G_ij) on
/// the common grid, with its own noise variances when known, so every single-channel tool
/// applies to one entry.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::data::FrfMatrix;
///
/// let omega = vec![1.0, 2.0, 3.0];
/// let g11 = vec![Complex::new(1.0, 0.0); 3];
/// let g21 = vec![Complex::new(0.0, 1.0); 3];
/// let m = FrfMatrix::from_entries(omega, 2, 1, vec![g11, g21], None).unwrap();
/// assert_eq!((m.ny(), m.nu(), m.len()), (2, 1, 3));
/// assert_eq!(m.entry(1, 0).y()[0], Complex::new(0.0, 1.0));
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct FrfMatrix<T: Real> {
    ny: usize,
    nu: usize,
    entries: Vec<FrequencyData<T>>,
    /// Per input column j and line k, the ny × ny covariance of the column's entries.
    #[cfg_attr(feature = "serde", serde(default))]
    covariances: Option<Vec<Vec<DMatrix<Complex<T>>>>>,
    #[cfg_attr(feature = "serde", serde(default))]
    input_noise: Option<Vec<Vec<InputNoise<T>>>>,
}

impl<T: Real> FrfMatrix<T> {
    /// Builds the matrix from its entries' responses (column by column, `ny·nu` vectors of
    /// one value per line of `omega`), with an optional sample time.
    ///
    /// # Errors
    /// `ny` or `nu` zero, a number of entries other than ny·nu, and every error of
    /// [`FrequencyData::from_frf`] (lengths, non-finite values, unsorted frequencies).
    pub fn from_entries(
        omega: Vec<T>,
        ny: usize,
        nu: usize,
        responses: Vec<Vec<Complex<T>>>,
        ts: Option<T>,
    ) -> Result<Self> {
        check_shape(ny, nu, responses.len())?;
        let entries = responses
            .into_iter()
            .map(|g| FrequencyData::from_frf(omega.clone(), g, ts))
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            ny,
            nu,
            entries,
            covariances: None,
            input_noise: None,
        })
    }

    /// Builds the matrix from single-channel data, one per entry (column by column), which
    /// must share their frequencies and sample time. Each entry is kept as its FRF
    /// Y_k/U_k with the variance of that ratio when the entry carries output noise
    /// variances (var_y/|U|²; input noise is not carried over).
    ///
    /// # Errors
    /// A shape that does not match, entries on different frequencies or sample times, a
    /// zero input on some line.
    pub fn from_data(ny: usize, nu: usize, data: Vec<FrequencyData<T>>) -> Result<Self> {
        check_shape(ny, nu, data.len())?;
        let first = &data[0];
        let mut entries = Vec::with_capacity(data.len());
        for (e, d) in data.iter().enumerate() {
            if d.omega() != first.omega() || d.ts() != first.ts() {
                return Err(FdidError::InvalidArgument {
                    name: "entries",
                    value: format!("entry {} of {}", e + 1, data.len()),
                    reason: "every entry must have the frequencies and sample time of the \
                             first"
                        .into(),
                });
            }
            let frf = d.etfe()?;
            let mut entry = FrequencyData::from_frf(d.omega().to_vec(), frf, d.ts())?;
            if let Some(noise) = d.noise() {
                let var: Vec<T> = noise
                    .var_y
                    .iter()
                    .zip(d.u())
                    .map(|(v, u)| *v / u.norm_sqr())
                    .collect();
                entry = entry.with_noise(NoiseVariances::output_only(var))?;
            }
            entries.push(entry);
        }
        Ok(Self {
            ny,
            nu,
            entries,
            covariances: None,
            input_noise: None,
        })
    }

    /// Attaches the noise variances of each entry's FRF (column by column, one per line).
    ///
    /// # Errors
    /// A number of entries other than ny·nu; wrong lengths, negative or non-finite values.
    pub fn with_variances(mut self, variances: Vec<Vec<T>>) -> Result<Self> {
        check_shape(self.ny, self.nu, variances.len())?;
        for (entry, var) in self.entries.iter_mut().zip(variances) {
            *entry = entry.clone().with_noise(NoiseVariances::output_only(var))?;
        }
        self.covariances = None;
        Ok(self)
    }

    /// Attaches the noise covariance of each input column: `covariances[j][k]` is the
    /// ny × ny covariance C_j(ω_k) of the column's entries (G_1j, …, G_nyj) at line k —
    /// off the diagonal the correlation of the outputs' noise (one disturbance seen by
    /// several sensors). The diagonals become the entries' variances; a common-pole fit
    /// weights the residual vector r of each column and line by C⁻¹ (rᴴC⁻¹r), see
    /// [`crate::mimo::CommonPoleOptions::full_covariance`].
    ///
    /// ```
    /// use fdid::prelude::*;
    /// use fdid::data::FrfMatrix;
    /// use nalgebra::DMatrix;
    ///
    /// let c = Complex::new(1.0, 0.0);
    /// let m = FrfMatrix::from_entries(vec![1.0, 2.0], 2, 1, vec![vec![c; 2]; 2], None)?;
    /// // unit variances, correlation 0.8 between the two outputs
    /// let cov = DMatrix::from_row_slice(2, 2, &[c, c * 0.8, c * 0.8, c]);
    /// let m = m.with_covariances(vec![vec![cov.clone(), cov]])?;
    /// assert!(m.has_variances());
    /// assert_eq!(m.covariance(0, 1).unwrap()[(1, 0)].re, 0.8);
    /// # Ok::<(), fdid::FdidError>(())
    /// ```
    ///
    /// # Errors
    /// Not nu columns of one matrix per line; a matrix not ny × ny, not finite, not
    /// Hermitian (to 10⁻⁸ of its diagonal), or with a diagonal that is not positive.
    pub fn with_covariances(mut self, covariances: Vec<Vec<DMatrix<Complex<T>>>>) -> Result<Self> {
        let bad = |value: String, reason: &str| FdidError::InvalidArgument {
            name: "covariances",
            value,
            reason: reason.into(),
        };
        if covariances.len() != self.nu {
            return Err(bad(
                format!("{} columns", covariances.len()),
                &format!("one list of covariances per input ({})", self.nu),
            ));
        }
        let lines = self.len();
        for (j, column) in covariances.iter().enumerate() {
            if column.len() != lines {
                return Err(bad(
                    format!("{} matrices for input {}", column.len(), j + 1),
                    &format!("one ny × ny covariance per line ({lines})"),
                ));
            }
            for (k, c) in column.iter().enumerate() {
                check_covariance(c, self.ny)
                    .map_err(|reason| bad(format!("input {}, line {}", j + 1, k + 1), &reason))?;
            }
        }
        for (e, entry) in self.entries.iter_mut().enumerate() {
            let (i, j) = (e % self.ny, e / self.ny);
            let var = covariances[j].iter().map(|c| c[(i, i)].re).collect();
            *entry = entry.clone().with_noise(NoiseVariances::output_only(var))?;
        }
        self.covariances = Some(covariances);
        Ok(self)
    }

    /// The ny × ny noise covariance of input column j's entries at line k, when attached
    /// by [`FrfMatrix::with_covariances`].
    pub fn covariance(&self, j: usize, k: usize) -> Option<&DMatrix<Complex<T>>> {
        self.covariances.as_ref().map(|c| &c[j][k])
    }

    /// True when the columns carry full ny × ny noise covariances.
    pub fn has_covariances(&self) -> bool {
        self.covariances.is_some()
    }

    /// Attaches the noise of each column's measured input (errors in variables):
    /// `noise[j][k]` for input j at line k, in FRF units ([`InputNoise`]). Needs the
    /// output covariances ([`FrfMatrix::with_covariances`]); the variances and
    /// covariances the fits weight by stay those of the outputs until
    /// [`FrfMatrix::at_response`] forms the errors-in-variables covariance at a response.
    ///
    /// ```
    /// use fdid::prelude::*;
    /// use fdid::data::{FrfMatrix, InputNoise};
    /// use nalgebra::{DMatrix, DVector};
    ///
    /// let g = Complex::new(2.0f64, 0.0);
    /// let m = FrfMatrix::from_entries(vec![1.0], 1, 1, vec![vec![g]], None)?
    ///     .with_covariances(vec![vec![DMatrix::from_element(1, 1, Complex::new(0.01, 0.0))]])?;
    /// // an input sensor's noise of 1 % of |U|² in variance, uncorrelated with the output's
    /// let input = InputNoise { cross: DVector::zeros(1), relative_variance: 0.01 };
    /// let m = m.with_input_noise(vec![vec![input]])?;
    /// // at G = 2: 0.01 + 4 × 0.01
    /// let at = m.at_response(|_| DMatrix::from_element(1, 1, g))?;
    /// assert!((at.covariance(0, 0).unwrap()[(0, 0)].re - 0.05).abs() < 1e-12);
    /// # Ok::<(), fdid::FdidError>(())
    /// ```
    ///
    /// # Errors
    /// No output covariances attached; not nu columns of one term per line; a `cross`
    /// not of length ny, or a value that is not finite or a negative variance.
    pub fn with_input_noise(mut self, noise: Vec<Vec<InputNoise<T>>>) -> Result<Self> {
        let bad = |value: String, reason: &str| FdidError::InvalidArgument {
            name: "input_noise",
            value,
            reason: reason.into(),
        };
        if self.covariances.is_none() {
            return Err(bad(
                "no output covariances".into(),
                "attach the outputs' covariances first (with_covariances)",
            ));
        }
        if noise.len() != self.nu {
            return Err(bad(
                format!("{} columns", noise.len()),
                &format!("one list per input ({})", self.nu),
            ));
        }
        let lines = self.len();
        for (j, column) in noise.iter().enumerate() {
            if column.len() != lines {
                return Err(bad(
                    format!("{} terms for input {}", column.len(), j + 1),
                    &format!("one per line ({lines})"),
                ));
            }
            for (k, n) in column.iter().enumerate() {
                let finite = n.cross.iter().all(|v| v.re.is_finite() && v.im.is_finite());
                if n.cross.len() != self.ny || !finite || !(n.relative_variance >= T::zero()) {
                    return Err(bad(
                        format!("input {}, line {}", j + 1, k + 1),
                        &format!(
                            "a cross covariance of {} finite values and a variance ≥ 0",
                            self.ny
                        ),
                    ));
                }
            }
        }
        self.input_noise = Some(noise);
        Ok(self)
    }

    /// The input's noise of column j at line k, when attached.
    pub fn input_noise(&self, j: usize, k: usize) -> Option<&InputNoise<T>> {
        self.input_noise.as_ref().map(|n| &n[j][k])
    }

    /// True when the columns carry their input's noise.
    pub fn has_input_noise(&self) -> bool {
        self.input_noise.is_some()
    }

    /// The matrix with each column's covariance replaced by the errors-in-variables one
    /// at the response `g(k)` (ny × nu at line k): C − c gᴴ − g cᴴ + g gᴴ s
    /// ([`InputNoise::covariance_at`]), the variances its diagonal; the input's noise is
    /// dropped (it is in the covariances now). Without input noise, a copy.
    ///
    /// # Errors
    /// A covariance that is no longer one (a diagonal not positive: the input terms do
    /// not come from the same periods as the outputs').
    pub fn at_response(&self, g: impl Fn(usize) -> DMatrix<Complex<T>>) -> Result<Self> {
        let (Some(covariances), Some(noise)) = (&self.covariances, &self.input_noise) else {
            return Ok(self.clone());
        };
        let mut totals = vec![Vec::with_capacity(self.len()); self.nu];
        for k in 0..self.len() {
            let at = g(k);
            for (j, total) in totals.iter_mut().enumerate() {
                let column = DVector::from_fn(self.ny, |i, _| at[(i, j)]);
                total.push(noise[j][k].covariance_at(&covariances[j][k], &column));
            }
        }
        let mut out = self.clone();
        out.input_noise = None;
        out.with_covariances(totals)
    }

    /// Outputs ny.
    pub fn ny(&self) -> usize {
        self.ny
    }

    /// Inputs nu.
    pub fn nu(&self) -> usize {
        self.nu
    }

    /// Number of frequency lines.
    pub fn len(&self) -> usize {
        self.entries[0].len()
    }

    /// Always false for a validated matrix.
    pub fn is_empty(&self) -> bool {
        self.entries[0].is_empty()
    }

    /// Angular frequencies (rad/s).
    pub fn omega(&self) -> &[T] {
        self.entries[0].omega()
    }

    /// Sample time, when the data are sampled.
    pub fn ts(&self) -> Option<T> {
        self.entries[0].ts()
    }

    /// Entry (i, j), zero-based: output i, input j.
    ///
    /// # Panics
    /// When i ≥ ny or j ≥ nu.
    pub fn entry(&self, i: usize, j: usize) -> &FrequencyData<T> {
        assert!(i < self.ny && j < self.nu, "entry ({i}, {j}) out of range");
        &self.entries[j * self.ny + i]
    }

    /// Every entry, column by column.
    pub fn entries(&self) -> &[FrequencyData<T>] {
        &self.entries
    }

    /// The (output, input) pair of the e-th entry in storage order, zero-based.
    pub fn position(&self, e: usize) -> (usize, usize) {
        (e % self.ny, e / self.ny)
    }

    /// True when every entry carries noise variances.
    pub fn has_variances(&self) -> bool {
        self.entries.iter().all(|e| e.noise().is_some())
    }

    /// Keeps the lines with `f_min ≤ f ≤ f_max` (Hz) in every entry.
    ///
    /// # Errors
    /// As [`FrequencyData::band_hz`].
    pub fn band_hz(&self, f_min: T, f_max: T) -> Result<Self> {
        let entries = self
            .entries
            .iter()
            .map(|e| e.band_hz(f_min, f_max))
            .collect::<Result<Vec<_>>>()?;
        // the kept lines are a run of the old ones: match them by frequency
        let first = self
            .omega()
            .iter()
            .position(|w| *w == entries[0].omega()[0])
            .unwrap_or(0);
        let kept = first..first + entries[0].len();
        let covariances = self.covariances.as_ref().map(|all| {
            all.iter()
                .map(|column| column[kept.clone()].to_vec())
                .collect()
        });
        let input_noise = self.input_noise.as_ref().map(|all| {
            all.iter()
                .map(|column| column[kept.clone()].to_vec())
                .collect()
        });
        Ok(Self {
            ny: self.ny,
            nu: self.nu,
            entries,
            covariances,
            input_noise,
        })
    }
}

/// Why `c` is not an ny × ny covariance, if it is not.
fn check_covariance<T: Real>(
    c: &DMatrix<Complex<T>>,
    ny: usize,
) -> std::result::Result<(), String> {
    if c.shape() != (ny, ny) {
        return Err(format!(
            "a {}×{} matrix; an {ny}×{ny} one is needed",
            c.nrows(),
            c.ncols()
        ));
    }
    if c.iter().any(|v| !(v.re.is_finite() && v.im.is_finite())) {
        return Err("a value is not finite".into());
    }
    for i in 0..ny {
        if !(c[(i, i)].re > T::zero()) {
            return Err(format!(
                "diagonal entry {} is {}, not positive",
                i + 1,
                c[(i, i)]
            ));
        }
    }
    for i in 0..ny {
        for j in 0..i {
            let scale = Float::sqrt(c[(i, i)].re * c[(j, j)].re);
            if (c[(i, j)] - c[(j, i)].conj()).norm() > scale * T::lit(1e-8) {
                return Err(format!(
                    "entries ({}, {}) and ({}, {}) are not conjugate",
                    i + 1,
                    j + 1,
                    j + 1,
                    i + 1
                ));
            }
        }
    }
    Ok(())
}

fn check_shape(ny: usize, nu: usize, entries: usize) -> Result<()> {
    if ny == 0 || nu == 0 || entries != ny * nu {
        return Err(FdidError::InvalidArgument {
            name: "entries",
            value: format!("{entries} entries for {ny} outputs × {nu} inputs"),
            reason: "a frequency response matrix needs ny·nu ≥ 1 entries".into(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shape_and_grid_mismatches_are_errors() {
        let c = Complex::new(1.0, 0.0);
        let bad = FrfMatrix::from_entries(vec![1.0, 2.0], 2, 2, vec![vec![c; 2]; 3], None);
        assert!(
            bad.unwrap_err()
                .to_string()
                .contains("3 entries for 2 outputs")
        );
        let a = FrequencyData::from_frf(vec![1.0, 2.0], vec![c; 2], None).unwrap();
        let b = FrequencyData::from_frf(vec![1.0, 3.0], vec![c; 2], None).unwrap();
        assert!(FrfMatrix::from_data(2, 1, vec![a.clone(), b]).is_err());
        let m = FrfMatrix::from_data(2, 1, vec![a.clone(), a]).unwrap();
        assert_eq!(m.position(1), (1, 0));
        assert!(!m.has_variances());
    }
}
