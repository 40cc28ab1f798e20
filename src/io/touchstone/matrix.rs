//! The matrix of one data row: its pairs of numbers as complex values, in the layout of
//! each version.

use super::options::Options;
use super::{NetworkParameter, NumberFormat};
use crate::scalar::Complex;

/// How the `[Network Data]` of a version 2 file writes each matrix (`[Matrix Format]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum MatrixFormat {
    /// Every entry.
    Full,
    /// The lower triangle with the diagonal, row by row, of a symmetric matrix.
    Lower,
    /// The upper triangle with the diagonal, row by row, of a symmetric matrix.
    Upper,
}

impl Options {
    /// The `ports × ports` matrix (row-major) of the pairs of one row, in physical units.
    pub(super) fn matrix(&self, pairs: &[f64], ports: usize) -> Vec<Complex<f64>> {
        let mut m = vec![Complex::new(0.0, 0.0); ports * ports];
        for (k, p) in pairs.chunks_exact(2).enumerate() {
            // version 1 writes the 2-port matrix column by column (X11 X21 X12 X22) and
            // every other one row by row
            let (i, j) = if ports == 2 {
                (k % 2, k / 2)
            } else {
                (k / ports, k % ports)
            };
            m[i * ports + j] = self.value(p) * self.scale(i, j);
        }
        m
    }

    /// The `ports × ports` matrix (row-major) of the pairs of one version 2 row: not
    /// normalised; `12_21` for the natural order of a full 2-port matrix, else that of
    /// version 1; a triangle mirrored for `Lower` and `Upper`.
    pub(super) fn matrix_v2(
        &self,
        pairs: &[f64],
        ports: usize,
        format: MatrixFormat,
        order_12_21: bool,
    ) -> Vec<Complex<f64>> {
        let n = ports;
        let cells: Vec<(usize, usize)> = match format {
            MatrixFormat::Full if n == 2 && !order_12_21 => vec![(0, 0), (1, 0), (0, 1), (1, 1)],
            MatrixFormat::Full => (0..n * n).map(|k| (k / n, k % n)).collect(),
            MatrixFormat::Lower => (0..n).flat_map(|i| (0..=i).map(move |j| (i, j))).collect(),
            MatrixFormat::Upper => (0..n).flat_map(|i| (i..n).map(move |j| (i, j))).collect(),
        };
        let mut m = vec![Complex::new(0.0, 0.0); ports * ports];
        for (p, (i, j)) in pairs.chunks_exact(2).zip(cells) {
            let x = self.value(p);
            m[i * ports + j] = x;
            if format != MatrixFormat::Full {
                m[j * ports + i] = x;
            }
        }
        m
    }

    /// The complex value of one pair.
    fn value(&self, p: &[f64]) -> Complex<f64> {
        match self.format {
            NumberFormat::RealImaginary => Complex::new(p[0], p[1]),
            NumberFormat::MagnitudeAngle => Complex::from_polar(p[0], p[1].to_radians()),
            NumberFormat::DecibelAngle => {
                Complex::from_polar(10f64.powf(p[0] / 20.0), p[1].to_radians())
            }
        }
    }

    /// The factor from the normalised value of entry `(i, j)` (0-based) to the physical one.
    fn scale(&self, i: usize, j: usize) -> f64 {
        let r = self.reference;
        match (self.parameter, i == j, i) {
            (NetworkParameter::S, _, _) => 1.0,
            (NetworkParameter::Z, _, _) => r,
            (NetworkParameter::Y, _, _) => 1.0 / r,
            (NetworkParameter::H, true, 0) | (NetworkParameter::G, true, 1) => r,
            (NetworkParameter::H, true, _) | (NetworkParameter::G, true, _) => 1.0 / r,
            (NetworkParameter::H | NetworkParameter::G, false, _) => 1.0,
        }
    }
}
