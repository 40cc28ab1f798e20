//! The time to read a CSV data file in a fresh process: the cost a user of `fdid fit`
//! meets before the fit (page faults of fresh memory, the thread pool's start, cold code),
//! which a benchmark that parses the same bytes again and again does not see.
//!
//! Run: `cargo run --release --example csv_read_time -- FILE [REPEATS]`. Prints the first
//! reading (the one a process makes) and, with `REPEATS > 1`, the median and fastest of
//! the readings in the same process. Run the program many times for the first reading's
//! spread; `docs/performance.md` ("Reading data files") gives the figures.

use fdid::io::read_csv;
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().ok_or("usage: csv_read_time FILE [REPEATS]")?;
    let repeats: usize = args.next().map_or(Ok(1), |s| s.parse())?;
    let mut times = Vec::with_capacity(repeats.max(1));
    for _ in 0..repeats.max(1) {
        let start = std::time::Instant::now();
        let data = read_csv::<f64>(Path::new(&path))?;
        times.push(start.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(data);
    }
    let first = times[0];
    times.sort_by(f64::total_cmp);
    println!(
        "first {first:.3} ms, median {:.3} ms, fastest {:.3} ms of {} readings",
        times[times.len() / 2],
        times[0],
        times.len()
    );
    Ok(())
}
