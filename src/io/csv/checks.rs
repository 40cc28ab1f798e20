//! Checks of the frequency and time columns.

/// Relative tolerance on the time grid: every `t_i` must lie within `1e-3·Ts` of
/// `t_0 + i·Ts`.
const TIME_GRID_TOLERANCE: f64 = 1e-3;

/// Frequencies (Hz) must be non-negative and strictly increasing. Errors carry the line
/// number (`lines[i]` of data row `i`).
pub(super) fn check_frequencies(
    f: &[f64],
    lines: &[usize],
) -> std::result::Result<(), (usize, String)> {
    let line = |i: usize| lines.get(i).copied().unwrap_or(0);
    for (i, &fi) in f.iter().enumerate() {
        if fi < 0.0 {
            return Err((line(i), format!("column `f`: negative frequency {fi} Hz")));
        }
        if i > 0 {
            let prev = f[i - 1];
            if fi == prev {
                return Err((
                    line(i),
                    format!(
                        "column `f`: duplicate frequency {fi} Hz (the previous row, line {}, \
                         has it too)",
                        line(i - 1)
                    ),
                ));
            }
            if fi < prev {
                return Err((
                    line(i),
                    format!(
                        "column `f`: frequency {fi} Hz is below the previous row's {prev} Hz \
                         (line {}): frequencies must increase",
                        line(i - 1)
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The sample time of the time column `t` of a record (s): `t` must hold at least two
/// finite values that increase strictly on a uniform grid, as a `t,u,y` file's column
/// must (the check of [`parse_csv`](super::parse_csv); errors name the sample index).
///
/// ```
/// assert_eq!(fdid::io::uniform_sample_time(&[0.0, 0.5, 1.0]).unwrap(), 0.5);
/// assert!(fdid::io::uniform_sample_time(&[0.0, 0.5, 1.2]).is_err());
/// ```
///
/// # Errors
/// [`FdidError::InvalidArgument`](crate::error::FdidError::InvalidArgument) naming the
/// first bad sample.
pub fn uniform_sample_time(t: &[f64]) -> crate::error::Result<f64> {
    let bad = |name, value, reason| crate::error::FdidError::InvalidArgument {
        name,
        value,
        reason,
    };
    if t.len() < 2 {
        return Err(bad(
            "time column",
            format!("{} value(s)", t.len()),
            "a record needs at least 2 samples".into(),
        ));
    }
    if let Some(k) = t.iter().position(|v| !v.is_finite()) {
        return Err(bad(
            "time sample",
            format!("t[{k}] = {}", t[k]),
            "not finite".into(),
        ));
    }
    let index: Vec<usize> = (0..t.len()).collect();
    check_time_grid(t, &index).map_err(|(k, m)| bad("time sample", format!("t[{k}]"), m))
}

/// Checks that the times increase strictly and lie on a uniform grid; returns
/// `Ts = (t_{N−1} − t_0)/(N − 1)`. Errors carry the line number: a step far from the
/// median step (a missing or extra row) is reported where it occurs, before the grid test
/// (which would name the first row that the skewed grid misses).
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
    if let Some(e) = irregular_step(t, &line) {
        return Err(e);
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

/// The first step `t_i − t_{i−1}` more than half the median step away from it, as an error
/// at row `i`, saying how many rows seem to be missing.
fn irregular_step(t: &[f64], line: &impl Fn(usize) -> usize) -> Option<(usize, String)> {
    let steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.len() < 2 {
        return None;
    }
    let mut sorted = steps.clone();
    let (_, &mut median, _) = sorted.select_nth_unstable_by(steps.len() / 2, f64::total_cmp);
    if !(median.is_finite() && median > 0.0) {
        return None;
    }
    let i = steps
        .iter()
        .position(|d| (d - median).abs() > 0.5 * median)?
        + 1;
    let step = steps[i - 1];
    let ratio = step / median;
    let what = if ratio > 1.5 && (ratio - ratio.round()).abs() < 0.1 {
        let k = ratio.round() - 1.0;
        format!(
            "{k} row{} missing before it?",
            if k == 1.0 { " seems" } else { "s seem" }
        )
    } else {
        "a row missing or extra, or the times of another file pasted in?".into()
    };
    Some((
        line(i),
        format!(
            "column `t`: t = {} is {step:.6e} s after the previous row (t = {}, line {}), but \
             the sample time is {median:.6e} s (the median step): {what}",
            t[i],
            t[i - 1],
            line(i - 1)
        ),
    ))
}
