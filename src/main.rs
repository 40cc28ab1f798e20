//! `fdid`: the command-line front end of the `fdid` crate.
//!
//! `fdid fit DATA --domain s|z --na N --nb M …` reads a CSV file (frequency response,
//! input/output spectra or a time record), fits a rational model and prints poles, zeros,
//! gain, cost, noise level, validation statistics and θ with standard deviations, as text
//! or as one JSON object. `--delay` adds a time delay G·e^{−iωτ} (McKelvey section 4),
//! `--transient` the transient term of a non-periodic record (eqs. 4–5, 9–10),
//! `--noise-order N` a noise model H = C/D estimated by maximum likelihood (eq. 26), and
//! `--criterion eiv` errors-in-variables maximum likelihood (eq. 42). Touchstone `.s1p`/`.s2p`
//! (version 1 or 2.0) and `.ts` (2.0) files are read as the FRF of one entry (`--port`). `--save FILE` writes the fitted model
//! as JSON; `fdid eval FILE --freq ...` evaluates it later, without the data.

mod cli;

use clap::Parser;
use std::io::Write;
use std::process::ExitCode;

use cli::Failure;
use cli::args::Cli;
use cli::message::one_line;

fn main() -> ExitCode {
    // A bug anywhere below must still end in one `error:` line, not a backtrace.
    std::panic::set_hook(Box::new(|info| {
        let what = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown failure".into());
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        eprintln!("error: internal error: {}{at}", one_line(&what));
    }));

    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => return cli::args::clap_failure(e),
    };
    match std::panic::catch_unwind(|| cli::progress::run(|| cli::run(&cli))) {
        Ok(Ok(out)) => {
            let mut stdout = std::io::stdout().lock();
            match stdout
                .write_all(out.as_bytes())
                .and_then(|()| stdout.flush())
            {
                Ok(()) => ExitCode::SUCCESS,
                // `fdid … | head`: the reader went away; not an error of ours
                Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
                Err(e) => report(&Failure::runtime(format!("cannot write the output: {e}"))),
            }
        }
        Ok(Err(f)) => report(&f),
        Err(_) => ExitCode::from(70),
    }
}

/// Prints the one-line error and returns its exit code.
fn report(f: &Failure) -> ExitCode {
    eprintln!("error: {}", one_line(&f.message));
    ExitCode::from(f.code)
}
