//! The real-data regression suite: the command on the bundled measurements and on the
//! measured sets in `../shared/data/`, each result checked against the reference its
//! data README gives (never against an earlier output of the command).
//!
//! | data | reference (README) |
//! | --- | --- |
//! | hair dryer (DaISy, `data/dryer.csv`) | input delay of 3 samples |
//! | robot arm (DaISy, `data/robot_arm.csv`) | order 4: resonances near bins 59 and 129 of 1024 (0.058 and 0.126 cycles/sample) |
//! | battery impedance (`data/eis_battery.csv`) | a distributed RC system: real poles (Voigt elements), no resonance |
#![cfg(feature = "cli")]
use crate::cli_common as cli;

use cli::{bundled, json};
use serde_json::Value;
use std::path::Path;

/// The `pole_details` of a `fdid fit --json` object: (f_n in Hz, damping) per pole.
fn modes(fit: &Value) -> Vec<(f64, f64)> {
    fit["pole_details"]
        .as_array()
        .expect("pole_details")
        .iter()
        .map(|p| {
            (
                p["f_n_hz"].as_f64().unwrap_or(f64::NAN),
                p["damping"].as_f64().unwrap_or(f64::NAN),
            )
        })
        .collect()
}

/// Whether a lightly damped (ζ < 0.2) pole lies within `tol` (relative) of `f_hz`.
fn has_mode(fit: &Value, f_hz: f64, tol: f64) -> bool {
    modes(fit)
        .iter()
        .any(|(f, z)| (f - f_hz).abs() <= tol * f_hz && *z > 0.0 && *z < 0.2)
}

#[test]
fn dryer_delay_is_three_samples_from_either_start() {
    let path = bundled("dryer.csv");
    for (na, nb) in [("1", "0"), ("2", "2")] {
        let report = json(
            "diagnose",
            Path::new(&path),
            &["--domain", "z", "--na", na, "--nb", nb],
        );
        let fin = &report["final"];
        let samples = fin["delay_samples"].as_f64().unwrap_or(f64::NAN);
        assert!(
            (samples - 3.0).abs() <= 0.5,
            "from {na}/{nb}: delay {samples} samples (reference 3)"
        );
        assert_eq!(fin["stable"], Value::Bool(true), "from {na}/{nb}");
        assert!(
            report["effects"]
                .as_array()
                .unwrap()
                .iter()
                .any(|e| e == "time_delay"),
            "from {na}/{nb}: {}",
            report["effects"]
        );
    }
}

#[test]
fn robot_arm_order_four_has_the_two_resonances() {
    let path = bundled("robot_arm.csv");
    let fit = json(
        "fit",
        Path::new(&path),
        &[
            "--domain",
            "z",
            "--na",
            "4",
            "--nb",
            "4",
            "--periods",
            "1",
            "--stable",
        ],
    );
    assert_eq!(fit["stable"], Value::Bool(true));
    for f in [59.0 / 1024.0, 129.0 / 1024.0] {
        assert!(
            has_mode(&fit, f, 0.03),
            "no mode near {f}: {:?}",
            modes(&fit)
        );
    }
}

#[test]
fn battery_impedance_steps_name_real_poles_missing_pole() {
    let path = bundled("eis_battery.csv");
    let report = json(
        "diagnose",
        Path::new(&path),
        &["--domain", "s", "--na", "1", "--nb", "1", "--band", ":1000"],
    );
    let fin = &report["final"];
    assert_eq!(fin["stable"], Value::Bool(true));
    let complex = modes(fin).iter().filter(|(_, z)| *z < 0.999).count();
    let resonances = report["effects"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| *e == "missing_resonance")
        .count();
    // every effect named missing_resonance added a complex pair to the final model
    assert!(
        2 * resonances <= complex,
        "{resonances} missing_resonance steps, {complex} complex poles: {:?}",
        modes(fin)
    );
}
