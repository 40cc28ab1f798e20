//! The header of a CSV file: the layout its column names give.

use crate::io::lines::echo;

/// The three file layouts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    Frf,
    Spectra,
    Time,
}

impl Kind {
    /// The kind the column names point to: their columns of values first, then those of
    /// variances.
    fn of_header(names: &[String]) -> std::result::Result<Self, String> {
        let has = |c: &str| names.iter().any(|n| n == c);
        let any = |cs: &[&str]| cs.iter().any(|c| has(c));
        if any(&["re", "im"]) {
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
            Kind::Spectra => "spectra",
            Kind::Time => "time-record",
        }
    }

    fn required(self) -> &'static [&'static str] {
        match self {
            Kind::Frf => &["f", "re", "im"],
            Kind::Spectra => &["f", "u_re", "u_im", "y_re", "y_im"],
            Kind::Time => &["t", "u", "y"],
        }
    }

    fn optional(self) -> &'static [&'static str] {
        match self {
            Kind::Frf => &["var"],
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
}

impl Layout {
    /// The layout of the column names `names` (lower case, in file order): the kind they
    /// point to, every name allowed in it once, the required ones present.
    pub(super) fn from_header(names: &[String]) -> std::result::Result<Self, String> {
        let has = |c: &str| names.iter().any(|n| n == c);
        let kind = Kind::of_header(names)?;
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
        })
    }

    /// The position of `column` in the file.
    pub(super) fn index(&self, column: &str) -> Option<usize> {
        self.names.iter().position(|n| n == column)
    }
}
