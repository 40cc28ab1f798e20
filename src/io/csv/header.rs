//! The header of a CSV file: the layout its column names give.

use crate::io::lines::echo;

/// The four file layouts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    Frf,
    /// A frequency response matrix: `f,re_11,im_11,re_21,im_21,…[,var_11,…]`.
    Matrix,
    Spectra,
    Time,
}

/// The part, output and input (1-based) of a column of a frequency response matrix file:
/// `re_IJ`, `im_IJ`, `var_IJ` with one digit each for I and J, or `re_I_J` (any numbers).
pub(super) fn matrix_column(name: &str) -> Option<(&'static str, usize, usize)> {
    let (part, rest) = [("re", "re_"), ("im", "im_"), ("var", "var_")]
        .iter()
        .find_map(|(part, prefix)| name.strip_prefix(prefix).map(|r| (*part, r)))?;
    let digits = |t: &str| !t.is_empty() && t.len() <= 4 && t.bytes().all(|b| b.is_ascii_digit());
    let (i, j) = match rest.split_once('_') {
        Some((a, b)) if digits(a) && digits(b) => (a.parse().ok()?, b.parse().ok()?),
        None if rest.len() == 2 && digits(rest) => {
            let b = rest.as_bytes();
            (usize::from(b[0] - b'0'), usize::from(b[1] - b'0'))
        }
        _ => return None,
    };
    (i >= 1 && j >= 1).then_some((part, i, j))
}

impl Kind {
    /// The kind the column names point to: their columns of values first, then those of
    /// variances.
    pub(super) fn of_header(names: &[String]) -> std::result::Result<Self, String> {
        let has = |c: &str| names.iter().any(|n| n == c);
        let any = |cs: &[&str]| cs.iter().any(|c| has(c));
        if names
            .iter()
            .any(|n| n.starts_with("re_") || n.starts_with("im_"))
        {
            Ok(Kind::Matrix)
        } else if any(&["re", "im"]) {
            Ok(Kind::Frf)
        } else if any(&["u_re", "u_im", "y_re", "y_im"]) {
            Ok(Kind::Spectra)
        } else if any(&["t", "u", "y"]) {
            Ok(Kind::Time)
        } else if has("var") {
            Ok(Kind::Frf)
        } else if any(&["var_u", "var_y"]) {
            Ok(Kind::Spectra)
        } else if has("f") {
            Err(format!(
                "header `{}`: missing columns: frequency data need `re`, `im` (FRF) or \
                 `u_re`, `u_im`, `y_re`, `y_im` (spectra)",
                echo(&names.join(","))
            ))
        } else {
            Err(format!(
                "unrecognized header `{}`: expected columns f,re,im (FRF), \
                 f,u_re,u_im,y_re,y_im (spectra) or t,u,y (time record)",
                echo(&names.join(","))
            ))
        }
    }

    fn label(self) -> &'static str {
        match self {
            Kind::Frf => "frequency-response",
            Kind::Matrix => "frequency-response-matrix",
            Kind::Spectra => "spectra",
            Kind::Time => "time-record",
        }
    }

    fn required(self) -> &'static [&'static str] {
        match self {
            Kind::Frf => &["f", "re", "im"],
            Kind::Matrix => &["f"],
            Kind::Spectra => &["f", "u_re", "u_im", "y_re", "y_im"],
            Kind::Time => &["t", "u", "y"],
        }
    }

    fn optional(self) -> &'static [&'static str] {
        match self {
            Kind::Frf => &["var"],
            Kind::Matrix => &[],
            Kind::Spectra => &["var_u", "var_y"],
            Kind::Time => &[],
        }
    }

    fn allowed(self) -> String {
        let mut all: Vec<&str> = self.required().to_vec();
        all.extend(self.optional().iter().copied());
        all.join(", ")
    }
}

/// The layout of a file: its kind and the column names in file order.
pub(super) struct Layout {
    pub(super) kind: Kind,
    pub(super) names: Vec<String>,
    /// Outputs and inputs of a frequency response matrix file, and whether it has the
    /// variances of its entries.
    pub(super) matrix: Option<(usize, usize, bool)>,
}

/// The shape of a frequency response matrix file from its column names: every name `f`
/// or a [`matrix_column`], none twice, `re_IJ` and `im_IJ` for every entry of the
/// ny × nu matrix, and `var_IJ` for all entries or none.
fn matrix_shape(names: &[String]) -> std::result::Result<(usize, usize, bool), String> {
    let mut cells = Vec::new();
    for (j, n) in names.iter().enumerate() {
        if names[..j].contains(n) {
            return Err(format!("duplicate column `{}`", echo(n)));
        }
        if n == "f" {
            continue;
        }
        match matrix_column(n) {
            Some(c) => cells.push(c),
            None => {
                return Err(format!(
                    "unknown column `{}` in frequency-response-matrix data (allowed: f, \
                     re_IJ, im_IJ, var_IJ for output I and input J, e.g. re_21; re_I_J \
                     beyond 9)",
                    echo(n)
                ));
            }
        }
    }
    if !names.iter().any(|n| n == "f") {
        return Err(
            "missing column `f` (frequency-response-matrix data need f, re_IJ, im_IJ)".into(),
        );
    }
    let ny = cells.iter().map(|c| c.1).max().unwrap_or(0);
    let nu = cells.iter().map(|c| c.2).max().unwrap_or(0);
    let has = |part: &'static str, i: usize, j: usize| cells.contains(&(part, i, j));
    let with_var = cells.iter().any(|c| c.0 == "var");
    for j in 1..=nu {
        for i in 1..=ny {
            for part in ["re", "im"] {
                if !has(part, i, j) {
                    return Err(format!(
                        "missing column `{part}_{i}{j}`: a {ny} x {nu} matrix (outputs x \
                         inputs, from the largest indices) needs re_IJ and im_IJ for every \
                         entry"
                    ));
                }
            }
            if with_var && !has("var", i, j) {
                return Err(format!(
                    "missing column `var_{i}{j}`: give the variance of every entry or of none"
                ));
            }
        }
    }
    Ok((ny, nu, with_var))
}

impl Layout {
    /// The layout of the column names `names` (lower case, in file order): the kind they
    /// point to, every name allowed in it once, the required ones present.
    pub(super) fn from_header(names: &[String]) -> std::result::Result<Self, String> {
        let has = |c: &str| names.iter().any(|n| n == c);
        let kind = Kind::of_header(names)?;
        if kind == Kind::Matrix {
            return Ok(Self {
                kind,
                names: names.to_vec(),
                matrix: Some(matrix_shape(names)?),
            });
        }
        for (j, n) in names.iter().enumerate() {
            if n.is_empty() {
                return Err(format!("empty column name in header (column {})", j + 1));
            }
            if !kind.required().contains(&n.as_str()) && !kind.optional().contains(&n.as_str()) {
                return Err(format!(
                    "unknown column `{}` in {} data (allowed: {})",
                    echo(n),
                    kind.label(),
                    kind.allowed()
                ));
            }
            if names[..j].contains(n) {
                return Err(format!("duplicate column `{}`", echo(n)));
            }
        }
        if let Some(m) = kind.required().iter().find(|c| !has(c)) {
            return Err(format!(
                "missing column `{m}` ({} data need {})",
                kind.label(),
                kind.required().join(", ")
            ));
        }
        Ok(Self {
            kind,
            names: names.to_vec(),
            matrix: None,
        })
    }

    /// The position of `column` in the file.
    pub(super) fn index(&self, column: &str) -> Option<usize> {
        self.names.iter().position(|n| n == column)
    }
}
