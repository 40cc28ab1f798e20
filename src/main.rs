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
    keep_freed_memory();
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
            room_for(out.len());
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

/// Tunes glibc's allocator for a short run: buffers up to 8 MiB come from the heap
/// instead of fresh mappings, and freed memory stays with the process (up to 64 MiB
/// above the top, 8 MiB of padding) instead of being returned and faulted in again at the
/// next use — the per-relocation buffers of a common-pole fit and the packing buffers of
/// every matrix product. On the 4-port of `bench/multiport.py`: 2 700 → 1 900 page faults,
/// about 0.7 ms less (`perf stat -r 100`); the 8-port unchanged (0.71 s, peak memory
/// 126 → 138 MB).
fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt takes two integers and changes glibc's tuning only; it runs before
    // any other thread exists, and a refused setting leaves the default.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 8 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 64 << 20);
        libc::mallopt(libc::M_TOP_PAD, 8 << 20);
    }
}

/// Widens the pipe on standard output (when it is one) to hold `bytes`, up to the
/// system's limit for unprivileged processes (1 MiB by default): a report larger than the
/// default 64 KiB is then written at once and the program exits, instead of waiting for
/// the reader to drain the pipe chunk by chunk (the JSON report of a 4-port fit is
/// 400 kB). Nothing changes when stdout is a file or terminal, or the call fails.
fn room_for(bytes: usize) {
    #[cfg(target_os = "linux")]
    {
        const DEFAULT_PIPE: usize = 1 << 16;
        const MOST: usize = 1 << 20;
        if bytes <= DEFAULT_PIPE {
            return;
        }
        // SAFETY: fstat fills the zeroed stat buffer we own, and F_SETPIPE_SZ takes an
        // integer size; both act on descriptor 1 only and report failure by their return.
        unsafe {
            let mut st: libc::stat = std::mem::zeroed();
            if libc::fstat(1, &mut st) == 0 && (st.st_mode & libc::S_IFMT) == libc::S_IFIFO {
                libc::fcntl(1, libc::F_SETPIPE_SZ, bytes.min(MOST) as libc::c_int);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = bytes;
}

/// Prints the one-line error and returns its exit code.
fn report(f: &Failure) -> ExitCode {
    eprintln!("error: {}", one_line(&f.message));
    ExitCode::from(f.code)
}
