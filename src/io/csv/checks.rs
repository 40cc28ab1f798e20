//! Checks of the frequency and time columns.

use crate::error::{FdidError, Result};

/// Relative tolerance on the time grid: every `t_i` must lie within `1e-3·Ts` of
/// `t_0 + i·Ts`.
const TIME_GRID_TOLERANCE: f64 = 1e-3;

/// Frequencies (Hz) must be non-negative and strictly increasing.
pub(super) fn check_frequencies(f: &[f64]) -> Result<()> {
    for (i, &fi) in f.iter().enumerate() {
        if fi < 0.0 {
            return Err(FdidError::NegativeFrequency {
                index: i,
                value: fi,
            });
        }
        if i > 0 {
            let prev = f[i - 1];
            if fi == prev {
                return Err(FdidError::DuplicateFrequency {
                    index: i,
                    value: fi,
                });
            }
            if fi < prev {
                return Err(FdidError::Unsorted {
                    index: i,
                    value: fi,
                    previous: prev,
                });
            }
        }
    }
    Ok(())
}

/// Checks that the times increase strictly and lie on a uniform grid; returns
/// `Ts = (t_{N−1} − t_0)/(N − 1)`. Errors carry the line number.
pub(super) fn check_time_grid(
    t: &[f64],
    lines: &[usize],
) -> std::result::Result<f64, (usize, String)> {
    let line = |i: usize| lines.get(i).copied().unwrap_or(0);
    for i in 1..t.len() {
        if t[i] <= t[i - 1] {
            return Err((
                line(i),
                format!(
                    "column `t`: time {} does not increase (previous row has t = {})",
                    t[i],
                    t[i - 1]
                ),
            ));
        }
    }
    let n = t.len();
    let t0 = t[0];
    let ts = (t[n - 1] - t0) / (n - 1) as f64;
    if !(ts.is_finite() && ts > 0.0) {
        return Err((
            0,
            format!("column `t`: sample time Ts = {ts} is not usable"),
        ));
    }
    for (i, &ti) in t.iter().enumerate() {
        let grid = t0 + i as f64 * ts;
        let dev = (ti - grid).abs();
        let tol = TIME_GRID_TOLERANCE * ts + 8.0 * f64::EPSILON * ti.abs().max(t0.abs());
        if dev > tol {
            return Err((
                line(i),
                format!(
                    "column `t`: non-uniform sampling: t = {ti} is {dev:.3e} s from the \
                     uniform grid t_0 + {i}·Ts = {grid} (Ts = {ts} s, tolerance {:.0e}·Ts)",
                    TIME_GRID_TOLERANCE
                ),
            ));
        }
    }
    Ok(ts)
}
