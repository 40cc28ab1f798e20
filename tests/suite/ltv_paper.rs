//! A reduced run of `examples/ltv_paper.rs` (Lataire–Pintelon section V): the same
//! system (N_α = 4, N_β = 2, N_p = 2, two drifting resonances and a moving zero pair),
//! band [0, 200] Hz and estimator, on a 2¹¹-sample record at f_s = 2048 Hz (T = 1 s, 201
//! lines: the poles and zeros travel the same path four times faster than in the
//! example), for three multisine realisations. The assertions check the shape of the
//! paper's results with margins below the measured figures (all in dB of the RMS
//! instantaneous-FRF error relative to the RMS FRF, over 50 instants and the band).
//!
//! Measured (seeds 1, 2, 3):
//!
//! | case | seed 1 | seed 2 | seed 3 |
//! |---|---|---|---|
//! | A no transient polynomial | −10.7 | −12.5 | −19.7 |
//! | B N_tr = 3 | −14.0 | −18.1 | −64.4 |
//! | B′ N_tr = 4 | −74.3 | −52.8 | −94.8 |
//! | C N_tr = 3, f_s halved | −26.5 | −16.8 | −51.8 |
//! | C′ N_tr = 4, f_s halved | −53.4 | −43.3 | −82.9 |
//! | D N_tr = 7 | −158.0 | −164.2 | −165.8 |
//! | noisy, monomial bases (mean of 6) | 2.8 | 1.9 | −1.0 |
//! | noisy, Legendre bases (mean of 6) | −13.4 | −11.7 | −14.7 |
//!
//! Not reproduced: the paper's B (N_tr = max(N_α, N_β) − 1 = 3) lying 30 dB below A. Here
//! B gains 3 … 45 dB over A depending on the realisation (and is 14 dB *worse* than A for
//! one realisation of the 2¹³-sample example), so it is not asserted. The DFT of the
//! output, whose periodic extension jumps at the record's ends, carries a term of order
//! N_α that an order-3 polynomial cannot absorb (see the example's documentation); with
//! N_tr = 4 (B′) the shape the paper reports for B holds, and it is asserted.

#[allow(dead_code)]
#[path = "../../examples/ltv_paper.rs"]
mod paper;

use fdid::FdidError;
use paper::{Bases, Experiment, fit, mean_db, noisy};

const FS: f64 = 2048.0;
const LOG2_N: u32 = 11;
const RTOL: f64 = 1e-10;
const SEEDS: [u64; 3] = [1, 2, 3];

/// FRF error (dB) of the Legendre-basis fit with transient order `ntr` on the record
/// sampled at f_s / `factor`.
fn error(exp: &Experiment, ntr: Option<usize>, factor: usize) -> f64 {
    let data = exp.decimated(factor).unwrap();
    exp.frf_error_db(&fit(&data, ntr, Bases::Legendre).unwrap().0)
}

/// Noise-free cases: the transient + alias polynomial of order 4 takes the error at least
/// 30 dB below no polynomial (measured ≥ 40.3 dB); order 7 (case D) at least 60 dB below
/// order 3 (measured ≥ 101 dB), 50 dB below order 4 (measured ≥ 71 dB), and below
/// −140 dB (measured ≤ −158 dB; the paper reports about −120 dB); halving f_s (case C′)
/// costs at least 3 dB at N_tr = 4 (measured 9.5 … 20.9 dB: more alias error).
#[test]
fn transient_polynomial_orders_have_the_papers_shape() {
    for seed in SEEDS {
        let exp = Experiment::new(FS, LOG2_N, RTOL, seed).unwrap();
        let a = error(&exp, None, 1);
        let b = error(&exp, Some(3), 1);
        let b4 = error(&exp, Some(4), 1);
        let c4 = error(&exp, Some(4), 2);
        let d = error(&exp, Some(7), 1);
        println!("seed {seed}: A {a:.1}, B {b:.1}, B' {b4:.1}, C' {c4:.1}, D {d:.1} dB");
        assert!(b4 < a - 30.0, "seed {seed}: B' {b4:.1} vs A {a:.1} dB");
        assert!(d < b - 60.0, "seed {seed}: D {d:.1} vs B {b:.1} dB");
        assert!(d < b4 - 50.0, "seed {seed}: D {d:.1} vs B' {b4:.1} dB");
        assert!(d < -140.0, "seed {seed}: D {d:.1} dB");
        assert!(c4 > b4 + 3.0, "seed {seed}: C' {c4:.1} vs B' {b4:.1} dB");
    }
}

/// Noisy case (28 dB SNR of coloured noise on u and y, N_tr = 3): Legendre bases in t and
/// s give a mean error at least 10 dB below monomials (measured 13.6 … 16.2 dB), and the
/// monomial error is of the order of the FRF itself (measured −1.0 … 2.8 dB; asserted
/// above −6 dB), as in the paper.
#[test]
fn legendre_bases_beat_monomials_with_noise() {
    for seed in SEEDS {
        let exp = Experiment::new(FS, LOG2_N, RTOL, seed).unwrap();
        let mean = |bases: Bases| {
            let errs: Vec<f64> = (0..6)
                .map(|r| {
                    let data = noisy(&exp.data, 100 + r).unwrap();
                    exp.frf_error_db(&fit(&data, Some(3), bases).unwrap().0)
                })
                .collect();
            mean_db(&errs)
        };
        let (mono, leg) = (mean(Bases::Monomial), mean(Bases::Legendre));
        println!("seed {seed}: monomial {mono:.1} dB, Legendre {leg:.1} dB");
        assert!(leg < mono - 10.0, "seed {seed}: {leg:.1} vs {mono:.1} dB");
        assert!(mono > -6.0, "seed {seed}: monomial {mono:.1} dB");
    }
}

/// The set-up rejects a sampling rate whose Nyquist frequency is below the band: a typed
/// error naming the band.
#[test]
fn band_above_nyquist_is_a_typed_error() {
    match Experiment::new(256.0, 8, RTOL, 1) {
        Err(FdidError::InvalidArgument { name, value, .. }) => {
            assert_eq!(name, "band_hz");
            assert!(value.contains("200"), "{value}");
        }
        other => panic!("expected InvalidArgument, got {:?}", other.map(|_| ())),
    }
}
