//! The data rows of both versions: the order of their frequencies and the message for a
//! row cut short.

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
        return Err(format!("negative frequency `{field}`"));
    }
    if !f.is_finite() {
        return Err(format!("frequency `{field}` is out of range in Hz"));
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
