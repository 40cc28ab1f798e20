//! The option line `# <unit> <parameter> <format> R <ref>` of both versions.

use super::{NetworkParameter, NumberFormat};
use crate::io::lines::echo;

/// The settings of the option line.
#[derive(Debug, Clone, Copy)]
pub(super) struct Options {
    /// Hz per frequency unit.
    pub(super) unit: f64,
    pub(super) parameter: NetworkParameter,
    pub(super) format: NumberFormat,
    pub(super) reference: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            unit: 1e9,
            parameter: NetworkParameter::S,
            format: NumberFormat::MagnitudeAngle,
            reference: 50.0,
        }
    }
}

impl Options {
    /// Parses the fields after `#`.
    pub(super) fn parse(rest: &str) -> std::result::Result<Self, String> {
        let mut o = Self::default();
        let mut seen = [false; 4];
        let mut once = |slot: usize, field: &str| {
            if std::mem::replace(&mut seen[slot], true) {
                Err(format!(
                    "option line: `{}` repeats a setting given before",
                    echo(field)
                ))
            } else {
                Ok(())
            }
        };
        let mut fields = rest.split_whitespace();
        while let Some(field) = fields.next() {
            let upper = field.to_ascii_uppercase();
            if let Some(unit) = unit(&upper) {
                once(0, field)?;
                o.unit = unit;
            } else if let Some(parameter) = parameter(&upper) {
                once(1, field)?;
                o.parameter = parameter;
            } else if let Some(format) = number_format(&upper) {
                once(2, field)?;
                o.format = format;
            } else if upper == "R" {
                once(3, field)?;
                o.reference = reference(fields.next())?;
            } else {
                return Err(format!(
                    "option line: unknown field `{}` (expected a unit Hz/kHz/MHz/GHz, \
                     a parameter S/Y/Z/H/G, a format RI/MA/DB or R <ohms>)",
                    echo(field)
                ));
            }
        }
        Ok(o)
    }
}

/// Hz per frequency unit of an upper-case unit field.
fn unit(field: &str) -> Option<f64> {
    match field {
        "HZ" => Some(1.0),
        "KHZ" => Some(1e3),
        "MHZ" => Some(1e6),
        "GHZ" => Some(1e9),
        _ => None,
    }
}

/// The kind of parameters of an upper-case parameter field.
fn parameter(field: &str) -> Option<NetworkParameter> {
    match field {
        "S" => Some(NetworkParameter::S),
        "Y" => Some(NetworkParameter::Y),
        "Z" => Some(NetworkParameter::Z),
        "H" => Some(NetworkParameter::H),
        "G" => Some(NetworkParameter::G),
        _ => None,
    }
}

/// The number format of an upper-case format field.
fn number_format(field: &str) -> Option<NumberFormat> {
    match field {
        "RI" => Some(NumberFormat::RealImaginary),
        "MA" => Some(NumberFormat::MagnitudeAngle),
        "DB" => Some(NumberFormat::DecibelAngle),
        _ => None,
    }
}

/// The reference resistance of the field after `R`: positive and finite.
fn reference(value: Option<&str>) -> std::result::Result<f64, String> {
    let value = value
        .ok_or_else(|| "option line: `R` needs the reference resistance after it".to_string())?;
    let r: f64 = value.parse().map_err(|_| {
        format!(
            "option line: reference resistance `{}` is not a number",
            echo(value)
        )
    })?;
    if !(r.is_finite() && r > 0.0) {
        return Err(format!(
            "option line: reference resistance {value} must be positive and finite"
        ));
    }
    Ok(r)
}
