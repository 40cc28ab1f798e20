//! The integration tests, one module per area (`tests/suite/NAME.rs`), compiled into one
//! test binary: the crate's generic code is instantiated and optimised once for all of
//! them instead of once per file. Run one area with a name filter, e.g.
//! `cargo test --release --all-features --test suite stress_numerical::`.

#[path = "../common/mod.rs"]
mod common;

#[cfg(feature = "cli")]
#[path = "../common/cli.rs"]
mod cli_common;

#[path = "../common/robustness.rs"]
mod robustness;

#[path = "../common/drifting.rs"]
mod drifting;

#[path = "../common/measurement.rs"]
mod measurement;

mod architecture;
mod batch;
mod cli;
mod cli_diagnose;
mod cli_ltv;
mod cli_mimo;
mod cli_raw;
mod cli_stable;
mod cli_unresolved;
mod cli_usability;
mod data_distortion;
mod data_lines;
mod data_lpm;
mod data_merge;
mod data_merge_fit;
mod data_periodic;
mod data_time;
mod estimators_band;
mod estimators_eiv;
mod estimators_errors;
mod estimators_from_poles;
mod estimators_jacobian;
mod estimators_montecarlo;
mod estimators_noise_model;
mod estimators_recovery;
mod estimators_scale;
mod estimators_stable;
mod fit_uncertainty;
mod greybox;
mod greybox_transient;
mod io_csv;
mod io_touchstone;
mod io_touchstone_v2;
mod ltv_lti;
mod ltv_paper;
mod ltv_varying;
mod mimo;
mod mimo_common_denominator;
mod mimo_covariance;
mod mimo_passivity;
mod mimo_periodic;
mod mimo_records;
mod mimo_stabilisation;
mod model_delay;
mod model_modal;
mod model_rational;
mod model_start_lines;
mod model_transient;
mod model_wideband;
mod optimisation_robustness;
mod real_data;
mod robustness_degenerate;
mod robustness_fuzz;
mod robustness_garbage;
mod robustness_input;
mod robustness_messages;
mod saved_model;
mod silverbox;
mod simd_paths;
mod simulate;
mod stress_numerical;
mod work_budget;
mod workflow_combined;
mod workflow_common_poles;
mod workflow_detect;
mod workflow_greybox;
mod workflow_honesty;
mod workflow_lrt;
mod workflow_ltv;
mod workflow_measurement;
mod workflow_noise;
mod workflow_segments;
mod workflow_spec;
mod workflow_tvswitch;
