//! Raw measurement files read without conversion: the channel tables of the benchmarks
//! (F-16 ground vibration test, Silverbox) and DaISy `.dat` files, by the library
//! (`fdid::io::read_channels`) and by the command (`--input`, `--output`, `--ts`). The
//! shared data sets are found at `../shared/data` relative to the crate root; the checks
//! are the reference facts of their READMEs.
#![cfg(feature = "cli")]

use crate::cli_common as cli;

use cli::{F16_LEVEL1 as F16, F16_RECORD, bundled, json, run, shared, stderr};
use fdid::io::{ChannelSelection, Column, read_channels};
use std::path::PathBuf;

fn select(input: &str, output: &str, ts: Option<f64>) -> ChannelSelection {
    ChannelSelection {
        input: Column::parse(input),
        output: Column::parse(output),
        ts,
    }
}

/// The F-16 file as it is (quoted header, trailing empty field, `Fs` only in the first
/// row): the README's F-16 command prepares 8 averaged periods of 8192 samples and the 267
/// excited lines of 2..15 Hz (README: lines 41..307, 2.00-14.99 Hz).
#[test]
fn f16_command_reads_and_prepares_the_excited_band() {
    let path = shared(F16);
    let args = |extra: &[&'static str]| {
        let mut a = F16_RECORD.to_vec();
        a.extend([
            "--output",
            "Acceleration1",
            "--domain",
            "s",
            "--na",
            "4",
            "--nb",
            "4",
        ]);
        a.extend_from_slice(extra);
        a
    };
    // with and without --band: the gap rule finds the multisine's 267 lines (DFT lines
    // 41…307 of 8192, README) among the 4097
    for extra in [&["--band", "2:15"][..], &[][..]] {
        let v = json("fit", &path, &args(extra));
        assert_eq!(v["lines"], 267, "{extra:?}");
        assert_eq!(v["lines_excited"], 267, "{extra:?}");
        let f = v["frf"].as_array().unwrap();
        let first = f[0][0].as_f64().unwrap();
        let last = f[f.len() - 1][0].as_f64().unwrap();
        assert!((first - 41.0 * 400.0 / 8192.0).abs() < 1e-9, "{first}");
        assert!((last - 307.0 * 400.0 / 8192.0).abs() < 1e-9, "{last}");
        assert!(v["weighting"].as_str().unwrap().contains("noise variance"));
    }
}

/// The F-16 FRF Force → Acceleration1 over periods 2-9 (library reader): the README's
/// peaks at 5.22 Hz (first flexible mode, wing bending) and 7.32 Hz (wing torsion) are
/// local maxima of |Y/U| within ±0.05 Hz.
#[test]
fn f16_frf_has_the_reference_modes() {
    let rec = read_channels::<f64>(
        &shared(F16),
        &select("Force", "Acceleration1", Some(0.0025)),
    )
    .unwrap();
    assert_eq!(rec.len(), 73_728);
    let steady = rec.skip_samples(8192).unwrap();
    assert!(steady.period_mismatch(8).unwrap() < fdid::data::PERIODICITY_TOLERANCE);
    let avg = steady.average_periods(8).unwrap();
    let g: Vec<f64> = (0..avg.len())
        .map(|k| (avg.y()[k] / avg.u()[k]).norm())
        .collect();
    let df = 400.0 / 8192.0;
    for f_ref in [5.22, 7.32] {
        let k0 = ((f_ref - 0.3) / df) as usize;
        let k1 = ((f_ref + 0.3) / df) as usize;
        let kmax = (k0..=k1).max_by(|a, b| g[*a].total_cmp(&g[*b])).unwrap();
        let f = kmax as f64 * df;
        assert!(
            (f - f_ref).abs() <= 0.05,
            "peak near {f_ref} Hz found at {f} Hz"
        );
    }
}

/// The raw Silverbox file (`"V1","V2",` with a trailing field): 131,072 rows; realisation
/// 0's steady-state period (README: samples [40986, 49178)) excites the odd lines, the even
/// lines hold about 1e-4 of that power (below 1e-3 here).
#[test]
fn silverbox_raw_file_reads_and_selects() {
    let path = shared("silverbox/SNLS80mV.csv");
    let rec = read_channels::<f64>(&path, &select("V1", "V2", Some(0.0016384))).unwrap();
    assert_eq!(rec.len(), 131_072);
    let (a, b) = (40_486 + 500, 40_486 + 8692);
    let u = &rec.u()[a..b];
    let mean = u.iter().sum::<f64>() / u.len() as f64;
    let centred: Vec<f64> = u.iter().map(|x| x - mean).collect();
    let big_u = fdid::data::dft_lines(&centred);
    let power = |parity: usize| -> f64 {
        (1..=2683)
            .filter(|k| k % 2 == parity)
            .map(|k| big_u[k].norm_sqr())
            .sum()
    };
    let ratio = power(0) / power(1);
    assert!(ratio < 1e-3 && ratio > 0.0, "even/odd power {ratio}");
    // the same columns by index, and a bad name listing the available ones
    let by_index = read_channels::<f64>(&path, &select("1", "2", Some(0.0016384))).unwrap();
    assert_eq!(by_index.u()[a], rec.u()[a]);
    let o = run(
        "fit",
        &path,
        &[
            "--input",
            "V3",
            "--output",
            "V2",
            "--ts",
            "0.0016384",
            "--domain",
            "z",
            "--na",
            "2",
            "--nb",
            "2",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("V3") && e.contains("`V1`") && e.contains("`V2`"),
        "{e}"
    );
}

/// DaISy `.dat` files (whitespace-separated, no header) by 1-based index give the same
/// fits as the bundled CSV conversions (the same numbers).
#[test]
fn daisy_dat_files_by_index_match_the_bundled_conversions() {
    let fit = |path: &std::path::Path, extra: &[&str], model: &[&str]| {
        let mut a = extra.to_vec();
        a.extend_from_slice(model);
        json("fit", path, &a)
    };
    let z4 = ["--domain", "z", "--na", "4", "--nb", "4"];
    let cases: [(&str, &[&str], &str, &[&str]); 4] = [
        (
            "daisy-robot-arm/robot_arm.dat",
            &["--input", "1", "--output", "2", "--ts", "1"],
            "robot_arm.csv",
            &[],
        ),
        (
            "daisy-dryer/dryer.dat",
            &["--input", "1", "--output", "2", "--ts", "0.08"],
            "dryer.csv",
            &[],
        ),
        (
            "daisy-cd-player-arm/CD_player_arm.dat",
            &["--input", "1", "--output", "3", "--ts", "1"],
            "cd_player_arm.csv",
            &["--input", "u1", "--output", "y1"],
        ),
        (
            "daisy-cd-player-arm/CD_player_arm.dat",
            &["--input", "2", "--output", "4", "--ts", "1"],
            "cd_player_arm.csv",
            &["--input", "u2", "--output", "y2"],
        ),
    ];
    for (dat, dat_args, csv, csv_args) in cases {
        let a = fit(&shared(dat), dat_args, &z4);
        let b = fit(std::path::Path::new(&bundled(csv)), csv_args, &z4);
        // the same numbers; Ts of a t column may differ from the given one in the last bit
        let (pa, pb) = (
            a["poles"].as_array().unwrap(),
            b["poles"].as_array().unwrap(),
        );
        assert_eq!(pa.len(), pb.len(), "{dat} vs {csv}");
        for (x, y) in pa.iter().zip(pb) {
            for j in 0..2 {
                let (x, y) = (x[j].as_f64().unwrap(), y[j].as_f64().unwrap());
                assert!(
                    (x - y).abs() <= 1e-9 * (1.0 + x.abs()),
                    "{dat} vs {csv}: {x} vs {y}"
                );
            }
        }
        assert_eq!(a["lines"], b["lines"], "{dat} vs {csv}");
    }
    // an index beyond the columns, and a name on a file without header
    let dat = shared("daisy-cd-player-arm/CD_player_arm.dat");
    for (args, want) in [
        (["--input", "5", "--output", "1"], "1..4"),
        (["--input", "u1", "--output", "3"], "no header"),
    ] {
        let mut a = args.to_vec();
        a.extend(["--ts", "1", "--domain", "z", "--na", "2", "--nb", "2"]);
        let o = run("fit", &dat, &a);
        assert_eq!(o.status.code(), Some(1));
        assert!(stderr(&o).contains(want), "{}", stderr(&o));
    }
    // without --ts a file without a t column says what is missing
    let o = run(
        "fit",
        &dat,
        &[
            "--input", "1", "--output", "3", "--domain", "z", "--na", "2", "--nb", "2",
        ],
    );
    assert!(stderr(&o).contains("--ts"), "{}", stderr(&o));
    // the bundled CD player arm without --input/--output points to them
    let o = run(
        "fit",
        std::path::Path::new(&bundled("cd_player_arm.csv")),
        &["--domain", "z", "--na", "2", "--nb", "2"],
    );
    assert!(stderr(&o).contains("--input"), "{}", stderr(&o));
}

/// The bundled Silverbox record (10 blocks of 8192 samples, each a new phase realisation):
/// `--periods 10` is refused with a pointer to `--realisations`; `--realisations 10` fits
/// the BLA weighted by its total variance, and a second-order model has its resonance at
/// the README's ≈ 69.8 Hz peak with ζ ≈ 0.04 (natural frequency 69.3-70.0 Hz, ζ in
/// 0.035-0.055).
#[test]
fn silverbox_realisations_give_the_bla_resonance() {
    let path = PathBuf::from(bundled("silverbox.csv"));
    let o = run(
        "fit",
        &path,
        &["--periods", "10", "--domain", "s", "--na", "2", "--nb", "0"],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--realisations 10"), "{}", stderr(&o));
    let v = json(
        "fit",
        &path,
        &[
            "--realisations",
            "10",
            "--band",
            ":200",
            "--domain",
            "s",
            "--na",
            "2",
            "--nb",
            "0",
        ],
    );
    assert!(
        v["weighting"].as_str().unwrap().contains("total variance"),
        "{}",
        v["weighting"]
    );
    assert!(
        v["notes"].to_string().contains("cannot be separated"),
        "{}",
        v["notes"]
    );
    let p = &v["poles"][0];
    let (re, im) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
    let wn = (re * re + im * im).sqrt();
    let (f_n, zeta) = (wn / std::f64::consts::TAU, -re / wn);
    assert!((69.3..=70.0).contains(&f_n), "f_n = {f_n} Hz");
    assert!((0.035..=0.055).contains(&zeta), "zeta = {zeta}");
}
