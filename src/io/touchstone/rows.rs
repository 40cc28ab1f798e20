//! The data rows of both versions: the order of their frequencies and the message for a
//! row cut short.

use crate::io::lines::echo;

/// The message for a row of `width` numbers cut short after `row`.
pub(super) fn short_row(row: &[f64], width: usize, ports: usize) -> String {
    format!(
        "the row of frequency {} ends after {} of its {width} numbers (f and {} pairs for \
         {ports} port{})",
        row[0],
        row.len(),
        (width - 1) / 2,
        if ports == 1 { "" } else { "s" }
    )
}

/// A frequency must be non-negative and above the previous one.
pub(super) fn check_frequency(
    f: f64,
    previous: Option<f64>,
    field: &str,
) -> std::result::Result<(), String> {
    if f < 0.0 {
        return Err(format!("negative frequency `{}`", echo(field)));
    }
    if !f.is_finite() {
        return Err(format!("frequency `{}` is out of range in Hz", echo(field)));
    }
    if let Some(p) = previous
        && f <= p
    {
        return Err(format!(
            "frequency {f} Hz is not above the previous one, {p} Hz: frequencies must \
             increase strictly"
        ));
    }
    Ok(())
}
