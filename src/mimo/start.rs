//! Starting poles of the common-pole relocation: lightly damped pairs spread over the
//! band where the data vary, or over the whole band.

use super::poles::PoleSet;
use crate::error::{FdidError, Result};
use crate::model::Domain;
use crate::scalar::{Complex, Real};
use num_traits::Float;
use std::cmp::Ordering;

/// The share of the data's variation left outside the active band at each end.
const TRIM: f64 = 0.01;

/// The share of the band (in its spacing's coordinate) below which the data's active band
/// replaces it.
const ACTIVE: f64 = 0.9;

/// Starting poles of vector fitting for order `n` over the band [`w_min`, `w_max`] (rad/s):
/// ⌊n/2⌋ lightly damped pairs −β/100 ± iβ with β evenly spaced over [max(w_min,
/// w_max/100), w_max] — in s over more than a decade, logarithmically spaced over
/// [max(w_min, 10⁻⁶w_max), w_max] — and one real pole −w_max/10 for odd n (Gustavsen and
/// Semlyen's recommended start), mapped to e^{pTs} in z.
pub(crate) fn over_band<T: Real>(
    n: usize,
    w_min: T,
    w_max: T,
    domain: Domain<T>,
) -> Result<PoleSet<T>> {
    if !(w_max > T::zero()) {
        return Err(FdidError::InvalidArgument {
            name: "band",
            value: format!("[{w_min}, {w_max}] rad/s"),
            reason: "vector fitting needs lines above 0".into(),
        });
    }
    let np = n / 2;
    let (lo, log_spaced) = lower_edge(w_min, w_max, domain);
    let pairs: Vec<T> = (0..np)
        .map(|j| spaced(lo, w_max, evenly(j, np), log_spaced))
        .collect();
    Ok(lightly_damped(&pairs, n % 2 == 1, w_max, domain))
}

/// Starting poles for order `n` placed from the data, or `None` when the data do not
/// place them (fewer than three lines, no variation above the noise, fewer line intervals
/// in the band than pairs). The blocks' values `value(e, k)` at lines of fitting frequency
/// `freq[k]` (Im x in s, the angle ωTs in z) give
///
/// 1. each block's noise variance from its second differences over the sorted lines,
///    σ̂²_e = median_k |h_e,k+1 − 2h_e,k + h_e,k−1|² / (6 ln 2) (complex Gaussian noise:
///    |d²|² is exponential with mean 6σ²; the median ignores the resonances);
/// 2. the variation of each line interval above that noise, relative to the data's size:
///    v_k = (Σ_e max(|h_e,k+1 − h_e,k|² − 2σ̂²_e, 0))^{1/2} / ½(‖h_k‖ + ‖h_k+1‖) — a
///    resonance turns each entry's phase by about π wherever its size;
/// 3. the active band: the lines between 1 % and 99 % of the cumulative variation;
/// 4. the starting band: the active band when it covers less than 90 % of the measured
///    band (in the spacing's coordinate: log ω in s over more than a decade, else ω),
///    else the measured band, whose start is then [`over_band`]'s;
/// 5. the pairs β_j spread over the starting band as in [`over_band`] (evenly in that
///    coordinate, ends included), unless a line interval would hold two of them — two
///    starting poles between the same two lines are one basis column twice: then at the
///    quantiles (j + ½)/⌊n/2⌋ of the intervals' widths, each interval's share capped at
///    one pair.
///
/// The pairs are −β/100 ± iβ and an odd order adds −ω_top/10, ω_top the starting band's
/// top (as [`over_band`]). Data
/// whose resonances fill a fraction of the measured band start where they are: the 4-port
/// of `bench/multiport.py` (resonances over two of its 3.3 decades) relocates 3 times
/// instead of 9, its 8-port 3 times instead of 7, to the same cost.
pub(crate) fn from_data<T: Real>(
    freq: &[T],
    blocks: usize,
    value: impl Fn(usize, usize) -> Complex<T>,
    n: usize,
    domain: Domain<T>,
) -> Option<PoleSet<T>> {
    let np = n / 2;
    let lines = freq.len();
    if np == 0 || lines < 3 || blocks == 0 {
        return None;
    }
    let mut order: Vec<usize> = (0..lines).collect();
    order.sort_by(|a, b| freq[*a].partial_cmp(&freq[*b]).unwrap_or(Ordering::Equal));
    let sorted: Vec<T> = order.iter().map(|k| freq[*k]).collect();
    let (w_min, w_max) = (sorted[0], sorted[lines - 1]);
    if !(w_max > T::zero()) {
        return None;
    }
    let (active_lo, active_hi) = active_band(&sorted, &variation(&order, blocks, &value))?;
    // the band's own start unless the data vary over less than 90 % of it
    let (full_lo, full_log) = lower_edge(w_min, w_max, domain);
    let span = |lo: T, hi: T| {
        if full_log {
            Float::ln(hi / lo)
        } else {
            hi - lo
        }
    };
    let (lo, hi, log_spaced) = if span(Float::max(active_lo, full_lo), active_hi)
        < T::lit(ACTIVE) * span(full_lo, w_max)
    {
        let (lo, log_spaced) = lower_edge(active_lo, active_hi, domain);
        (lo, active_hi, log_spaced)
    } else {
        (full_lo, w_max, full_log)
    };
    let coordinate = |f: T| {
        let f = Float::min(Float::max(f, lo), hi);
        if log_spaced { Float::ln(f) } else { f }
    };
    let widths: Vec<T> = sorted
        .windows(2)
        .map(|w| coordinate(w[1]) - coordinate(w[0]))
        .collect();
    // evenly spaced pairs unless a line interval would hold two of them
    let step = (coordinate(hi) - coordinate(lo)) / T::from_usize_lossy(np.max(2) - 1);
    let pairs = if widths.iter().all(|w| *w < step) {
        (0..np)
            .map(|j| spaced(lo, hi, evenly(j, np), log_spaced))
            .collect()
    } else {
        let shares = capped_shares(&widths, np)?;
        let mut pairs = Vec::with_capacity(np);
        let mut below = T::zero();
        let mut k = 0;
        for j in 0..np {
            let q = (T::from_usize_lossy(j) + T::lit(0.5)) / T::from_usize_lossy(np);
            while k + 1 < shares.len() && below + shares[k] < q {
                below += shares[k];
                k += 1;
            }
            let t = if shares[k] > T::zero() {
                Float::min(Float::max((q - below) / shares[k], T::zero()), T::one())
            } else {
                T::lit(0.5)
            };
            let (a, b) = (coordinate(sorted[k]), coordinate(sorted[k + 1]));
            let c = a + (b - a) * t;
            pairs.push(if log_spaced { Float::exp(c) } else { c });
        }
        pairs
    };
    if pairs
        .iter()
        .any(|b| !(*b > T::zero() && Float::is_finite(*b)))
    {
        return None;
    }
    Some(lightly_damped(&pairs, n % 2 == 1, hi, domain))
}

/// The variation above the noise of each interval between consecutive lines (in the
/// frequency `order`), relative to the data's size (step 2 of [`from_data`]).
fn variation<T: Real>(
    order: &[usize],
    blocks: usize,
    value: &impl Fn(usize, usize) -> Complex<T>,
) -> Vec<T> {
    let noise: Vec<T> = (0..blocks)
        .map(|e| {
            let mut d2: Vec<T> = order
                .windows(3)
                .map(|w| {
                    (value(e, w[2]) - value(e, w[1]) * T::lit(2.0) + value(e, w[0])).norm_sqr()
                })
                .collect();
            crate::stats::median(&mut d2) / T::lit(6.0 * std::f64::consts::LN_2)
        })
        .collect();
    let size =
        |k: usize| Float::sqrt((0..blocks).fold(T::zero(), |s, e| s + value(e, k).norm_sqr()));
    order
        .windows(2)
        .map(|w| {
            let above = (0..blocks).fold(T::zero(), |s, e| {
                let step = (value(e, w[1]) - value(e, w[0])).norm_sqr();
                s + Float::max(step - noise[e] * T::lit(2.0), T::zero())
            });
            let v = Float::sqrt(above) / ((size(w[0]) + size(w[1])) * T::lit(0.5));
            if Float::is_finite(v) { v } else { T::zero() }
        })
        .collect()
}

/// The band [lo, hi] between [`TRIM`] and 1 − [`TRIM`] of the cumulative variation (step 3
/// of [`from_data`]), or `None` when the data do not vary or the band is one point.
fn active_band<T: Real>(sorted: &[T], variation: &[T]) -> Option<(T, T)> {
    let total = variation.iter().fold(T::zero(), |s, v| s + *v);
    if !(total > T::zero() && Float::is_finite(total)) {
        return None;
    }
    let (mut lo, mut hi) = (None, sorted[sorted.len() - 1]);
    let mut cumulative = T::zero();
    for (k, v) in variation.iter().enumerate() {
        cumulative += *v / total;
        if lo.is_none() && cumulative >= T::lit(TRIM) {
            lo = Some(sorted[k]);
        }
        if cumulative >= T::lit(1.0 - TRIM) {
            hi = sorted[k + 1];
            break;
        }
    }
    let lo = lo?;
    (hi > lo && hi > T::zero()).then_some((lo, hi))
}

/// The shares of the line intervals' `widths` normalised to sum to 1, each at most 1/np
/// (the widths of the intervals below the cap scaled up to fill the rest), or `None` when
/// fewer than np intervals have a width.
fn capped_shares<T: Real>(widths: &[T], np: usize) -> Option<Vec<T>> {
    let cap = T::one() / T::from_usize_lossy(np);
    let mut shares = widths.to_vec();
    let mut capped = vec![false; shares.len()];
    loop {
        let held = capped.iter().filter(|c| **c).count();
        let free = shares
            .iter()
            .zip(&capped)
            .filter(|(_, c)| !**c)
            .fold(T::zero(), |s, (v, _)| s + *v);
        if held >= np || !(free > T::zero()) {
            return None;
        }
        let scale = (T::one() - T::from_usize_lossy(held) * cap) / free;
        let mut more = false;
        for (v, c) in shares
            .iter_mut()
            .zip(capped.iter_mut())
            .filter(|(_, c)| !**c)
        {
            *v *= scale;
            if *v > cap {
                *v = cap;
                *c = true;
                more = true;
            }
        }
        if !more {
            return Some(shares);
        }
    }
}

/// The fraction j/(np − 1) of the band at which pair j of np starts (½ for one pair).
fn evenly<T: Real>(j: usize, np: usize) -> T {
    if np == 1 {
        T::lit(0.5)
    } else {
        T::from_usize_lossy(j) / T::from_usize_lossy(np - 1)
    }
}

/// The frequency at `fraction` of [lo, hi]: logarithmically or linearly.
fn spaced<T: Real>(lo: T, hi: T, fraction: T, log_spaced: bool) -> T {
    if log_spaced {
        lo * Float::powf(hi / lo, fraction)
    } else {
        lo + (hi - lo) * fraction
    }
}

/// The lower edge of the starting band [lo, `w_max`] and whether the pairs are spaced
/// logarithmically: in s over more than a decade from max(`w_min`, 10⁻⁶w_max), else
/// evenly from max(`w_min`, w_max/100).
fn lower_edge<T: Real>(w_min: T, w_max: T, domain: Domain<T>) -> (T, bool) {
    let log_spaced =
        domain == Domain::Continuous && w_min > T::zero() && w_max > w_min * T::lit(10.0);
    let lo = if log_spaced {
        Float::max(w_min, w_max * T::lit(1e-6))
    } else {
        Float::max(w_min, w_max / T::lit(100.0))
    };
    (lo, log_spaced)
}

/// The pairs −β/100 + iβ at the frequencies β (and a real pole −w_max/10 when `odd`), in
/// s or mapped to e^p in z (unit sample time: β are angles).
fn lightly_damped<T: Real>(beta: &[T], odd: bool, w_max: T, domain: Domain<T>) -> PoleSet<T> {
    let pairs = beta.iter().map(|b| Complex::new(-*b / T::lit(100.0), *b));
    let real = odd.then(|| -w_max / T::lit(10.0));
    match domain {
        Domain::Continuous => PoleSet {
            real: real.into_iter().collect(),
            pairs: pairs.collect(),
        },
        Domain::Discrete { ts } => PoleSet {
            real: real.into_iter().map(|r| Float::exp(r * ts)).collect(),
            pairs: pairs.map(|p| (p * ts).exp()).collect(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2 × 2 response with lightly damped resonances at `modes` (rad/s) on `omega`, plus a
    /// direct term, and deterministic noise of size `noise`.
    fn resonant(omega: &[f64], modes: &[f64], noise: f64) -> Vec<Vec<Complex<f64>>> {
        (0..4)
            .map(|e| {
                omega
                    .iter()
                    .enumerate()
                    .map(|(k, w)| {
                        let s = Complex::new(0.0, *w);
                        let mut h = Complex::new(0.1 * (e as f64 + 1.0), 0.0);
                        for (m, wn) in modes.iter().enumerate() {
                            let p = Complex::new(-0.02 * wn, *wn);
                            let r = Complex::new(wn * 0.02 * (1.0 + 0.3 * (e + m) as f64), 0.1);
                            h += r / (s - p) + r.conj() / (s - p.conj());
                        }
                        let phase = 2.3 * (k * 7 + e * 13) as f64;
                        h + Complex::new(phase.cos(), phase.sin()) * noise
                    })
                    .collect()
            })
            .collect()
    }

    fn log_lines(lo: f64, hi: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|k| lo * (hi / lo).powf(k as f64 / (n - 1) as f64))
            .collect()
    }

    #[test]
    fn pairs_start_where_the_data_vary() {
        // resonances over 1–10 rad/s on lines over 0.01–1000 rad/s (five decades)
        let omega = log_lines(0.01, 1000.0, 400);
        let modes = [1.0, 1.7, 2.9, 4.4, 6.0, 8.1, 10.0];
        let h = resonant(&omega, &modes, 1e-6);
        let start = from_data(&omega, 4, |e, k| h[e][k], 14, Domain::Continuous).unwrap();
        let band = over_band(14, 0.01, 1000.0, Domain::Continuous).unwrap();
        assert_eq!((start.real.len(), start.pairs.len()), (0, 7));
        for p in &start.pairs {
            assert!(p.im > 0.3 && p.im < 50.0, "pair at {} rad/s", p.im);
            assert!((p.re + p.im / 100.0).abs() < 1e-12 * p.im);
        }
        // the band's start spreads them over all five decades
        assert!(band.pairs[0].im < 0.02 && band.pairs[6].im > 900.0);
    }

    #[test]
    fn a_band_the_data_fill_keeps_the_band_start() {
        let omega = log_lines(0.8, 12.0, 300);
        let modes = [1.0, 1.7, 2.9, 4.4, 6.0, 8.1, 10.0];
        let h = resonant(&omega, &modes, 1e-6);
        let start = from_data(&omega, 4, |e, k| h[e][k], 15, Domain::Continuous).unwrap();
        let band = over_band(15, 0.8, 12.0, Domain::Continuous).unwrap();
        assert_eq!(start, band);
    }

    #[test]
    fn no_line_interval_holds_two_starting_pairs() {
        // evenly spaced lines over more than a decade: the log-spaced band start puts 8 of
        // its 20 pairs below the second line
        let omega: Vec<f64> = (0..60).map(|k| 0.05 + k as f64 * 1.0).collect();
        let band = over_band(40, omega[0], omega[59], Domain::Continuous).unwrap();
        assert!(band.pairs.iter().filter(|p| p.im < omega[1]).count() >= 8);
        let modes: Vec<f64> = (0..20).map(|m| 2.0 + 2.9 * m as f64).collect();
        let h = resonant(&omega, &modes, 1e-6);
        let start = from_data(&omega, 4, |e, k| h[e][k], 40, Domain::Continuous).unwrap();
        for w in omega.windows(2) {
            let inside = start.pairs.iter().filter(|p| p.im >= w[0] && p.im < w[1]);
            assert!(inside.count() <= 1, "two pairs in [{}, {}]", w[0], w[1]);
        }
    }

    #[test]
    fn the_noise_does_not_widen_the_band() {
        // resonances over 1–10 rad/s; noise at 1 % of the direct term everywhere
        let omega = log_lines(0.01, 1000.0, 400);
        let modes = [1.0, 2.2, 4.4, 10.0];
        let h = resonant(&omega, &modes, 1e-3);
        let start = from_data(&omega, 4, |e, k| h[e][k], 8, Domain::Continuous).unwrap();
        for p in &start.pairs {
            assert!(p.im > 0.2 && p.im < 50.0, "pair at {} rad/s", p.im);
        }
    }

    #[test]
    fn data_that_do_not_place_the_start_say_so() {
        let omega = log_lines(0.1, 10.0, 50);
        let flat = vec![vec![Complex::new(0.3, -0.1); 50]; 2];
        assert!(from_data(&omega, 2, |e, k| flat[e][k], 6, Domain::Continuous).is_none());
        let h = resonant(&omega, &[1.0], 0.0);
        assert!(from_data(&omega[..2], 4, |e, k| h[e][k], 2, Domain::Continuous).is_none());
        assert!(from_data(&omega, 4, |e, k| h[e][k], 1, Domain::Continuous).is_none());
        // more pairs than line intervals
        let few = &omega[..6];
        assert!(from_data(few, 4, |e, k| h[e][k], 20, Domain::Continuous).is_none());
    }

    #[test]
    fn z_starts_are_on_the_unit_disc_map() {
        let angles: Vec<f64> = (1..200).map(|k| k as f64 * 3.1 / 200.0).collect();
        let omega_s: Vec<f64> = angles.to_vec();
        let h = resonant(&omega_s, &[0.3, 0.5, 0.7], 1e-6);
        let z = Domain::Discrete { ts: 1.0 };
        let start = from_data(&angles, 4, |e, k| h[e][k], 7, z).unwrap();
        // the band's start reaches 3.1 rad
        assert!(over_band(7, angles[0], angles[198], z).unwrap().pairs[2].arg() > 3.0);
        assert_eq!((start.real.len(), start.pairs.len()), (1, 3));
        for p in &start.pairs {
            assert!(p.norm() < 1.0 && p.arg() > 0.1 && p.arg() < 2.0, "{p}");
        }
        assert!(start.real[0] > 0.0 && start.real[0] < 1.0);
    }
}
