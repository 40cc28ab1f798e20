//! The keywords of a version 2 file, each checked where it stands and against those
//! given before.

use super::{Reader, Section};
use crate::error::Result;
use crate::io::lines::echo;
use crate::io::touchstone::NetworkParameter;
use crate::io::touchstone::matrix::MatrixFormat;

/// The keywords that take no argument.
const WITHOUT_ARGUMENT: [&str; 5] = [
    "network data",
    "noise data",
    "end",
    "begin information",
    "end information",
];

impl Reader<'_> {
    /// The keyword `kw` (normalised; `written` as in the file) with the argument `arg` on
    /// `line`.
    pub(super) fn keyword(
        &mut self,
        line: usize,
        kw: &str,
        written: &str,
        arg: &str,
    ) -> Result<()> {
        self.close_section(line, written)?;
        if self.section == Section::Options && kw != "number of ports" {
            return Err(self.error(
                line,
                format!("`[{written}]`: `[Number of Ports]` must follow the option line"),
            ));
        }
        if WITHOUT_ARGUMENT.contains(&kw) && !arg.is_empty() {
            return Err(self.error(
                line,
                format!(
                    "`[{written}]` takes no argument, got `{}` (data rows go on the lines \
                     after it)",
                    echo(arg)
                ),
            ));
        }
        match kw {
            "version" => Err(self.error(
                line,
                format!(
                    "`[{written}]` repeats the keyword of line {}",
                    self.version_line
                ),
            )),
            "number of ports" => self.number_of_ports(line, written, arg),
            "two port data order" => self.two_port_data_order(line, written, arg),
            "number of frequencies" => self.number_of_frequencies(line, written, arg),
            "number of noise frequencies" => self.number_of_noise_frequencies(line, written, arg),
            "reference" => self.reference(line, written, arg),
            "matrix format" => self.matrix_format(line, written, arg),
            "mixed mode order" => Err(self.error(
                line,
                format!(
                    "`[{written}]`: mixed-mode network data are not supported (only \
                     single-ended data)"
                ),
            )),
            "begin information" => self.begin_information(line, written),
            "end information" => self.end_information(line, written),
            "network data" => self.network_data(line, written),
            "noise data" => self.noise_data(line, written),
            "end" => self.end(line, written),
            _ => Err(self.error(
                line,
                format!("unknown Touchstone 2.0 keyword `[{}]`", echo(written)),
            )),
        }
    }

    /// The end of the section that the keyword `written` on `line` closes.
    fn close_section(&self, line: usize, written: &str) -> Result<()> {
        match self.section {
            Section::Reference => Err(self.error(
                line,
                format!(
                    "`[{written}]`: `[Reference]` (line {}) gives {} of the {} reference \
                     impedances",
                    self.reference_line,
                    self.references.len(),
                    self.ports().unwrap_or(1)
                ),
            )),
            Section::Network => self.close_network(line),
            Section::Version => Err(self.error(
                line,
                format!("`[{written}]`: the option line (`# ...`) must follow `[Version] 2.0`"),
            )),
            _ => Ok(()),
        }
    }

    /// A keyword given at most once: `seen` is the line of an earlier one.
    fn once(&self, line: usize, written: &str, seen: Option<usize>) -> Result<()> {
        match seen {
            Some(first) => Err(self.error(
                line,
                format!("`[{written}]` repeats the keyword of line {first}"),
            )),
            None => Ok(()),
        }
    }

    /// A keyword of the header, before `[Network Data]`.
    fn header_only(&self, line: usize, written: &str) -> Result<()> {
        if self.section == Section::Header {
            Ok(())
        } else {
            Err(self.error(
                line,
                format!("`[{written}]` must come before `[Network Data]`"),
            ))
        }
    }

    /// A count argument of the keyword `written` on `line`: a positive whole number.
    fn count(&self, line: usize, written: &str, arg: &str) -> Result<usize> {
        match arg.parse::<usize>() {
            Ok(n) if n > 0 => Ok(n),
            _ => Err(self.error(
                line,
                format!(
                    "`[{written}]` needs a positive whole number, got `{}`",
                    echo(arg)
                ),
            )),
        }
    }

    /// `[Number of Ports] n`: 1 to [`crate::io::MAX_PORTS`], as the extension names, right
    /// after the option line.
    fn number_of_ports(&mut self, line: usize, written: &str, arg: &str) -> Result<()> {
        self.once(line, written, self.h.ports.map(|p| p.1))?;
        let n = self.count(line, written, arg)?;
        if n > crate::io::MAX_PORTS {
            return Err(self.error(
                line,
                format!(
                    "`[{written}] {n}`: files of more than {} ports are not supported",
                    crate::io::MAX_PORTS
                ),
            ));
        }
        if let Some(e) = self.expected_ports.filter(|e| *e != n) {
            return Err(self.error(
                line,
                format!(
                    "`[{written}] {n}`, but the extension .s{e}p names {e} port{}",
                    if e == 1 { "" } else { "s" }
                ),
            ));
        }
        if n != 2
            && matches!(
                self.opts.parameter,
                NetworkParameter::H | NetworkParameter::G
            )
        {
            return Err(self.error(
                line,
                format!(
                    "`[{written}] {n}`: {} parameters are defined for 2 ports only",
                    self.opts.parameter.letter()
                ),
            ));
        }
        self.h.ports = Some((n, line));
        self.section = Section::Header;
        Ok(())
    }

    /// `[Two-Port Data Order] 12_21|21_12` of a 2-port file.
    fn two_port_data_order(&mut self, line: usize, written: &str, arg: &str) -> Result<()> {
        self.header_only(line, written)?;
        self.once(line, written, self.h.order_12_21.map(|o| o.1))?;
        if self.ports() != Some(2) {
            return Err(self.error(line, format!("`[{written}]` applies to 2-port files only")));
        }
        let order = match arg {
            "12_21" => true,
            "21_12" => false,
            _ => {
                return Err(self.error(
                    line,
                    format!("`[{written}]` needs 12_21 or 21_12, got `{}`", echo(arg)),
                ));
            }
        };
        self.h.order_12_21 = Some((order, line));
        Ok(())
    }

    /// `[Number of Frequencies] N`.
    fn number_of_frequencies(&mut self, line: usize, written: &str, arg: &str) -> Result<()> {
        self.header_only(line, written)?;
        self.once(line, written, self.h.frequencies.map(|f| f.1))?;
        self.h.frequencies = Some((self.count(line, written, arg)?, line));
        Ok(())
    }

    /// `[Number of Noise Frequencies] M` of a 2-port file.
    fn number_of_noise_frequencies(&mut self, line: usize, written: &str, arg: &str) -> Result<()> {
        self.header_only(line, written)?;
        self.once(line, written, self.h.noise_frequencies.map(|f| f.1))?;
        if self.ports() != Some(2) {
            return Err(self.error(
                line,
                format!("`[{written}]`: noise parameters are defined for 2 ports only"),
            ));
        }
        self.h.noise_frequencies = Some((self.count(line, written, arg)?, line));
        Ok(())
    }

    /// `[Reference] r1 … rn`, whose values may continue on the next lines.
    fn reference(&mut self, line: usize, written: &str, arg: &str) -> Result<()> {
        self.header_only(line, written)?;
        self.once(line, written, self.h.reference)?;
        self.h.reference = Some(line);
        self.reference_line = line;
        self.references(line, arg)
    }

    /// `[Matrix Format] Full|Lower|Upper`.
    fn matrix_format(&mut self, line: usize, written: &str, arg: &str) -> Result<()> {
        self.header_only(line, written)?;
        self.once(line, written, self.h.matrix.map(|m| m.1))?;
        let format = match arg.to_ascii_lowercase().as_str() {
            "full" => MatrixFormat::Full,
            "lower" => MatrixFormat::Lower,
            "upper" => MatrixFormat::Upper,
            _ => {
                return Err(self.error(
                    line,
                    format!(
                        "`[{written}]` needs Full, Lower or Upper, got `{}`",
                        echo(arg)
                    ),
                ));
            }
        };
        self.h.matrix = Some((format, line));
        Ok(())
    }

    /// `[Begin Information]`: the block up to `[End Information]` is skipped.
    fn begin_information(&mut self, line: usize, written: &str) -> Result<()> {
        self.header_only(line, written)?;
        self.once(line, written, self.h.information)?;
        self.h.information = Some(line);
        self.section = Section::Information;
        Ok(())
    }

    /// `[End Information]`, closing `[Begin Information]`.
    fn end_information(&mut self, line: usize, written: &str) -> Result<()> {
        if self.section != Section::Information {
            return Err(self.error(line, format!("`[{written}]` without `[Begin Information]`")));
        }
        self.section = Section::Header;
        Ok(())
    }

    /// `[Network Data]`, after the keywords its rows need.
    fn network_data(&mut self, line: usize, written: &str) -> Result<()> {
        self.header_only(line, written)?;
        let Some(n) = self.ports() else {
            return Err(self.error(
                line,
                "`[Network Data]` without `[Number of Ports]` before it".into(),
            ));
        };
        if self.h.frequencies.is_none() {
            return Err(self.error(
                line,
                "`[Network Data]` without `[Number of Frequencies]` before it".into(),
            ));
        }
        if n == 2 && self.h.order_12_21.is_none() {
            return Err(self.error(
                line,
                "`[Network Data]` of 2 ports without `[Two-Port Data Order]` (12_21 or \
                 21_12) before it"
                    .into(),
            ));
        }
        self.h.network = Some(line);
        let pairs = match self.h.matrix.map_or(MatrixFormat::Full, |m| m.0) {
            MatrixFormat::Full => n * n,
            _ => n * (n + 1) / 2,
        };
        self.width = 1 + 2 * pairs;
        self.section = Section::Network;
        Ok(())
    }

    /// `[Noise Data]`, after the network data when `[Number of Noise Frequencies]` was
    /// given.
    fn noise_data(&mut self, line: usize, written: &str) -> Result<()> {
        if self.section != Section::Network {
            return Err(self.error(
                line,
                format!("`[{written}]` must follow the rows of `[Network Data]`"),
            ));
        }
        if self.h.noise_frequencies.is_none() {
            return Err(self.error(
                line,
                format!(
                    "`[{written}]` without `[Number of Noise Frequencies]` before \
                     `[Network Data]`"
                ),
            ));
        }
        self.h.noise = Some(line);
        self.section = Section::Noise;
        Ok(())
    }

    /// `[End]`, after the network data and the noise data announced.
    fn end(&mut self, line: usize, written: &str) -> Result<()> {
        if self.section != Section::Network && self.section != Section::Noise {
            return Err(self.error(line, format!("`[{written}]` before `[Network Data]`")));
        }
        if let Some((_, at)) = self.h.noise_frequencies
            && self.h.noise.is_none()
        {
            return Err(self.error(
                line,
                format!(
                    "`[{written}]` without the `[Noise Data]` that \
                     `[Number of Noise Frequencies]` (line {at}) announces"
                ),
            ));
        }
        self.section = Section::End;
        Ok(())
    }
}
