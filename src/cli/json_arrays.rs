//! The large arrays of a JSON report written straight from the numbers: a real matrix as
//! an array of rows, an entry's response as `[f_hz, re, im]` per line. Built as a
//! `serde_json::Value` tree they cost one node per number (a 50-pole 4-port's state
//! space alone holds 40 000) before a byte is written.

use fdid::prelude::Complex;
use nalgebra::DMatrix;
use serde::ser::{Serialize, SerializeSeq, Serializer};

/// A real matrix as a JSON array of its rows (non-finite values as `null`, as
/// `serde_json` writes them).
pub(super) struct Rows<'a>(pub &'a DMatrix<f64>);

impl Serialize for Rows<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let m = self.0;
        let mut rows = serializer.serialize_seq(Some(m.nrows()))?;
        for i in 0..m.nrows() {
            rows.serialize_element(&Row(m, i))?;
        }
        rows.end()
    }
}

struct Row<'a>(&'a DMatrix<f64>, usize);

impl Serialize for Row<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq((0..self.0.ncols()).map(|j| self.0[(self.1, j)]))
    }
}

/// Entry (i, j) (from 0) of a response matrix per line as `[[f_hz, re, im], …]`.
pub(super) struct Response<'a> {
    pub f_hz: &'a [f64],
    pub g: &'a [DMatrix<Complex<f64>>],
    pub i: usize,
    pub j: usize,
}

impl Serialize for Response<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.f_hz.iter().zip(self.g).map(|(f, m)| {
            let v = m[(self.i, self.j)];
            [*f, v.re, v.im]
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn arrays_match_the_value_tree_they_replace() {
        let m = DMatrix::from_row_slice(2, 3, &[1.0, -2.5, 0.0, f64::NAN, 1e-300, 3.0]);
        let tree = json!([[1.0, -2.5, 0.0], [null, 1e-300, 3.0]]);
        assert_eq!(serde_json::to_value(Rows(&m)).unwrap(), tree);
        let g = vec![
            DMatrix::from_element(1, 2, Complex::new(0.5, -1.0)),
            DMatrix::from_element(1, 2, Complex::new(2.0, 0.25)),
        ];
        let r = Response {
            f_hz: &[10.0, 20.0],
            g: &g,
            i: 0,
            j: 1,
        };
        assert_eq!(
            serde_json::to_string(&r).unwrap(),
            "[[10.0,0.5,-1.0],[20.0,2.0,0.25]]"
        );
    }
}
