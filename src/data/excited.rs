//! Which lines of a measured input spectrum carry the excitation: the level, gap and grid
//! rules of [`FrequencyData::excitation`].

use crate::data::{FrequencyData, NoiseVariances};
use crate::error::{FdidError, Result};
use crate::scalar::Real;
use crate::stats::beta_reg;
use num_complex::Complex;

/// Smallest drop (dB) between two consecutive levels of the sorted `|U_k|` that
/// [`FrequencyData::excitation`] takes as the edge between excited and unexcited lines.
pub const EXCITATION_GAP_DB: f64 = 10.0;

/// Fewest lines on each side of a gap: at least this many below it (2 above). For a
/// random input `|U_k|²` is close to exponentially distributed, and a drop of 10 dB between
/// the `j`-th and `(j + 1)`-th smallest lines has probability about `10^{−j}`.
pub const EXCITATION_GAP_MIN_LINES: usize = 8;

/// How far (dB) a line must lie below both neighbours to be a dip of the grid rule.
pub const EXCITATION_DIP_DB: f64 = 20.0;

/// Significance of the grid rule: the dips are taken as a designed pattern of unexcited
/// lines when their count would have probability below this for a random input.
pub const EXCITATION_GRID_ALPHA: f64 = 1e-6;

/// Default number of unexcited lines averaged per variance by
/// [`FrequencyData::unexcited_noise`] (the degrees of freedom of each variance).
pub const UNEXCITED_NEIGHBOURS: usize = 10;

/// Which rule decided the excited lines of [`FrequencyData::excitation`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ExcitationRule {
    /// Every line above the fraction of the largest (no gap, no grid): a random input.
    Level,
    /// The lines above a drop of `gap_db` dB in the sorted levels (a band-limited or
    /// sparse multisine, the rest of the lines at the noise level).
    Gap {
        /// The drop in dB.
        gap_db: f64,
        /// The regular pattern the lines above the gap follow, if any (an odd multisine:
        /// lines 1 mod 2); lines above the gap off the pattern are disturbances (e.g. mains
        /// harmonics), neither fitted nor noise lines.
        pattern: Option<GridPattern>,
    },
    /// A grid of unexcited lines (e.g. the even lines of an odd multisine or sweep):
    /// `dips` lines lie [`EXCITATION_DIP_DB`] below both neighbours where a random input
    /// gives `expected`; `pattern` the regular pattern they follow, if any.
    Grid {
        /// Number of dips.
        dips: usize,
        /// Expected number for a random input.
        expected: f64,
        /// The pattern of excited and unexcited lines, when the dips follow one.
        pattern: Option<GridPattern>,
    },
}

/// A regular grid of excited lines: entry `k` of the band `first..=last` belongs to the
/// excited classes when `k mod stride` is one of them (e.g. stride 2, class 1: an odd
/// multisine).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GridPattern {
    /// The period of the pattern in lines (2 to 4).
    pub stride: usize,
    /// Bit `r` set when the class `k mod stride = r` is excited.
    pub excited_classes: u8,
    /// First entry of the band the pattern covers.
    pub first: usize,
    /// Last entry of the band.
    pub last: usize,
}

impl GridPattern {
    /// Whether entry `k` is in the band.
    pub fn covers(&self, k: usize) -> bool {
        (self.first..=self.last).contains(&k)
    }

    /// Whether entry `k` belongs to an excited class.
    pub fn excited_class(&self, k: usize) -> bool {
        self.excited_classes & (1 << (k % self.stride)) != 0
    }

    /// The excited classes as `r mod s` text, e.g. `1 mod 2`.
    pub fn describe(&self) -> String {
        let classes: Vec<String> = (0..self.stride)
            .filter(|r| self.excited_classes & (1 << r) != 0)
            .map(|r| r.to_string())
            .collect();
        format!("{} mod {}", classes.join(","), self.stride)
    }
}

impl ExcitationRule {
    /// Short name for text and JSON: `level`, `gap` or `grid`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Level => "level",
            Self::Gap { .. } => "gap",
            Self::Grid { .. } => "grid",
        }
    }
}

/// The excited lines of an input spectrum, the lines that carry only noise, and the rule
/// that found them.
#[derive(Debug, Clone, PartialEq)]
pub struct Excitation {
    lines: Vec<bool>,
    noise_lines: Vec<bool>,
    /// Lines above the gap left out because they are off the grid the others follow.
    off_grid: usize,
    floor: f64,
    rule: ExcitationRule,
}

impl Excitation {
    /// Per line, whether the input excites it.
    pub fn lines(&self) -> &[bool] {
        &self.lines
    }

    /// Per line, whether it is a noise line: one the input leaves out by design (below
    /// the gap, or an unexcited line of the grid). Lines that are neither excited nor
    /// noise lines (weak lines outside a grid's band, lines near the level of the
    /// unexcited ones) are used for neither.
    pub fn noise_lines(&self) -> &[bool] {
        &self.noise_lines
    }

    /// Number of excited lines.
    pub fn count(&self) -> usize {
        self.lines.iter().filter(|e| **e).count()
    }

    /// The level `|U|` below which no line is excited.
    pub fn floor(&self) -> f64 {
        self.floor
    }

    /// The rule that decided.
    pub fn rule(&self) -> ExcitationRule {
        self.rule
    }

    /// One phrase for reports, e.g. `grid 1 mod 2: 96 lines 20 dB below both
    /// neighbours (2.5 expected for a random input)`.
    pub fn describe(&self) -> String {
        match self.rule {
            ExcitationRule::Level => "level: |U| above the floor on every line".into(),
            ExcitationRule::Gap { gap_db, pattern } => {
                let gap = format!("gap: the lines above a {gap_db:.1} dB drop in the sorted |U|");
                match pattern {
                    Some(p) => format!(
                        "{gap}, on the grid of lines {} ({} line{} above the gap off the grid \
                         left out as disturbances)",
                        p.describe(),
                        self.off_grid,
                        if self.off_grid == 1 { "" } else { "s" }
                    ),
                    None => gap,
                }
            }
            ExcitationRule::Grid {
                dips,
                expected,
                pattern,
            } => {
                let found = format!(
                    "{dips} lines {EXCITATION_DIP_DB} dB below both neighbours ({expected:.1} \
                     expected for a random input)"
                );
                match pattern {
                    Some(p) => format!(
                        "grid, lines {} from line {} to {}: {found}",
                        p.describe(),
                        p.first,
                        p.last
                    ),
                    None => format!("grid: {found} left out, and those within 6 dB of their level"),
                }
            }
        }
    }
}

impl<T: Real> FrequencyData<T> {
    /// The lines the input excites, decided from `|U_k|` alone by three rules in turn
    /// (the DC line is never excited):
    ///
    /// 1. **Level.** `|U_k| > fraction · max_{j: ω_j > 0} |U_j|` (lines at the rounding
    ///    level of a designed excitation, see [`crate::data::EXCITATION_FRACTION`]).
    /// 2. **Gap.** Sort the levels `20 log₁₀|U_k|` of those lines; the largest drop
    ///    between consecutive levels with at least [`EXCITATION_GAP_MIN_LINES`] lines below
    ///    and 2 above, when it reaches [`EXCITATION_GAP_DB`], separates the excited lines
    ///    (above) from noise lines (below: a band-limited multisine, the unexcited lines of
    ///    an odd multisine). When the lines above follow a regular pattern (for the
    ///    smallest stride `s = 2, 3, 4`, from the first to the last line above the gap,
    ///    every class `k mod s` has ≥ 90 % or ≤ 10 % of its lines above), the few lines
    ///    above the gap off the pattern are disturbances (mains harmonics, say): neither
    ///    excited nor noise lines. The rules stop here.
    /// 3. **Grid.** Among the lines left, a *dip* is a line more than
    ///    [`EXCITATION_DIP_DB`] below both neighbouring entries (one at the ends). For a
    ///    random input (`|U_k|²` locally exponential) a line is a dip with probability
    ///    `p = 1 − 2/(2 + 10^{−DIP/10}) ≈ 0.005`. When the `d` dips among `n` lines are too
    ///    many for chance (`P(X ≥ d) = I_p(d, n − d + 1) <` [`EXCITATION_GRID_ALPHA`], and
    ///    `d ≥` [`EXCITATION_GAP_MIN_LINES`]), the input follows a designed grid.
    ///    - When the dips follow a pattern ([`GridPattern`]: for the smallest stride
    ///      `s = 2, 3, 4`, over the band from the first to the last dip that has two others
    ///      within `2s` lines, widened by `2s`, every class `k mod s` has either at least half
    ///      of its lines dips (unexcited class) or at most a tenth (excited class)), the
    ///      lines of the excited classes in the band are excited when `|U_k|` is more than
    ///      6 dB above the median level of the unexcited-class lines within `2s` lines; the
    ///      unexcited-class lines of the band are noise lines; lines outside the band are
    ///      neither.
    ///    - Otherwise the dips are noise lines, and the other lines are excited when more
    ///      than 6 dB above the 90th percentile of the dips' levels.
    ///
    /// A random input (noise, a random binary sequence) ends at rule 1: all lines but DC
    /// are excited, none is a noise line.
    ///
    /// ```
    /// use fdid::prelude::*;
    /// use num_complex::Complex;
    /// // an odd multisine: odd lines at 1, even lines at the noise level 1e-3
    /// let n = 64;
    /// let omega: Vec<f64> = (1..=n).map(|k| 0.01 * k as f64).collect();
    /// let u: Vec<Complex<f64>> = (1..=n)
    ///     .map(|k| Complex::new(if k % 2 == 1 { 1.0 } else { 1e-3 * (1.0 + 0.1 * (k % 5) as f64) }, 0.0))
    ///     .collect();
    /// let data = FrequencyData::new(omega, u.clone(), u, None).unwrap();
    /// let ex = data.excitation(1e-6);
    /// assert_eq!(ex.count(), n / 2);
    /// assert!(ex.lines().iter().enumerate().all(|(i, e)| *e == (i % 2 == 0)));
    /// assert!(ex.noise_lines().iter().enumerate().all(|(i, e)| *e == (i % 2 == 1)));
    /// ```
    pub fn excitation(&self, fraction: f64) -> Excitation {
        let level: Vec<f64> = self
            .omega()
            .iter()
            .zip(self.u())
            .map(|(w, u)| {
                if *w > T::zero() {
                    u.norm().to_f64_lossless()
                } else {
                    0.0
                }
            })
            .collect();
        let n = level.len();
        let mut floor = self.excitation_floor(fraction);
        let rule = ExcitationRule::Level;
        let mut noise_lines = vec![false; n];
        if let Some((gap_db, gap_floor)) = largest_gap(&level, floor) {
            floor = gap_floor;
            let kept: Vec<bool> = level.iter().map(|l| *l > floor).collect();
            let pattern = kept_pattern(&kept);
            let mut lines = kept.clone();
            if let Some(p) = &pattern {
                for (k, line) in lines.iter_mut().enumerate() {
                    *line &= p.covers(k) && p.excited_class(k);
                }
            }
            for (noise, l) in noise_lines.iter_mut().zip(&level) {
                *noise = *l > 0.0 && *l <= floor;
            }
            let off_grid = kept.iter().zip(&lines).filter(|(k, l)| **k && !**l).count();
            return Excitation {
                lines,
                noise_lines,
                off_grid,
                floor,
                rule: ExcitationRule::Gap { gap_db, pattern },
            };
        }
        let kept: Vec<bool> = level.iter().map(|l| *l > floor).collect();
        let dips = dips(&level);
        let dipped: Vec<usize> = (0..n).filter(|&k| kept[k] && dips[k]).collect();
        let p = 1.0 - 2.0 / (2.0 + 10f64.powf(-EXCITATION_DIP_DB / 10.0));
        let (m, d) = (kept.iter().filter(|k| **k).count(), dipped.len());
        let grid = d >= EXCITATION_GAP_MIN_LINES
            && beta_reg(d as f64, (m - d + 1) as f64, p) < EXCITATION_GRID_ALPHA;
        if !grid {
            return Excitation {
                off_grid: 0,
                lines: kept,
                noise_lines,
                floor,
                rule,
            };
        }
        let pattern = grid_pattern(&dipped, &kept);
        let mut lines = vec![false; n];
        match pattern {
            Some(pat) => {
                for k in (pat.first..=pat.last).filter(|&k| level[k] > 0.0) {
                    if !pat.excited_class(k) {
                        noise_lines[k] = true;
                        continue;
                    }
                    let lo = k.saturating_sub(2 * pat.stride).max(pat.first);
                    let hi = (k + 2 * pat.stride).min(pat.last);
                    let mut near: Vec<f64> = (lo..=hi)
                        .filter(|&j| !pat.excited_class(j) && level[j] > 0.0)
                        .map(|j| level[j])
                        .collect();
                    near.sort_by(f64::total_cmp);
                    let local = near.get(near.len() / 2).copied().unwrap_or(0.0);
                    lines[k] = kept[k] && level[k] > 2.0 * local;
                }
            }
            None => {
                let mut sorted: Vec<f64> = dipped.iter().map(|&k| level[k]).collect();
                sorted.sort_by(f64::total_cmp);
                let p90 = sorted[(0.9 * (d - 1) as f64).round() as usize];
                floor = floor.max(2.0 * p90);
                for &k in &dipped {
                    noise_lines[k] = true;
                }
                for k in 0..n {
                    lines[k] = level[k] > floor && !dips[k];
                }
            }
        }
        Excitation {
            lines,
            noise_lines,
            off_grid: 0,
            floor,
            rule: ExcitationRule::Grid {
                dips: d,
                expected: p * m as f64,
                pattern,
            },
        }
    }
}

/// The smallest-stride regular pattern the lines above the gap follow: over the band from
/// the first to the last of them, every class `k mod s` (`s = 2, 3, 4`) has at least 90 %
/// of its lines kept (excited class) or at most 10 % (unexcited class), and both kinds
/// occur.
fn kept_pattern(kept: &[bool]) -> Option<GridPattern> {
    let first = kept.iter().position(|k| *k)?;
    let last = kept.iter().rposition(|k| *k)?;
    (2..=4usize).find_map(|stride| {
        let mut excited_classes = 0u8;
        let mut unexcited = false;
        for r in 0..stride {
            let class: Vec<usize> = (first..=last).filter(|k| k % stride == r).collect();
            let hits = class.iter().filter(|&&k| kept[k]).count();
            let fraction = hits as f64 / class.len().max(1) as f64;
            if fraction >= 0.9 {
                excited_classes |= 1 << r;
            } else if fraction <= 0.1 {
                unexcited = true;
            } else {
                return None;
            }
        }
        (excited_classes != 0 && unexcited).then_some(GridPattern {
            stride,
            excited_classes,
            first,
            last,
        })
    })
}

/// The smallest-stride regular pattern the dips follow (see
/// [`FrequencyData::excitation`]), if any.
fn grid_pattern(dipped: &[usize], kept: &[bool]) -> Option<GridPattern> {
    (2..=4usize).find_map(|stride| {
        // a dip of the grid has at least two others within 2s lines (a random input
        // gives that with probability about 28 p² ≈ 7e-4 per dip)
        let dense: Vec<usize> = dipped
            .iter()
            .filter(|&&k| {
                dipped
                    .iter()
                    .filter(|&&j| j != k && j.abs_diff(k) <= 2 * stride)
                    .count()
                    >= 2
            })
            .copied()
            .collect();
        let first = dense.first()?.saturating_sub(2 * stride);
        let last = (dense.last()? + 2 * stride).min(kept.len() - 1);
        let mut excited_classes = 0u8;
        for r in 0..stride {
            let class: Vec<usize> = (first..=last)
                .filter(|k| k % stride == r && kept[*k])
                .collect();
            let hits = class
                .iter()
                .filter(|k| dipped.binary_search(k).is_ok())
                .count();
            let fraction = hits as f64 / class.len().max(1) as f64;
            if fraction <= 0.1 {
                excited_classes |= 1 << r;
            } else if fraction < 0.5 {
                return None;
            }
        }
        let all = (1u8 << stride) - 1;
        (excited_classes != 0 && excited_classes != all).then_some(GridPattern {
            stride,
            excited_classes,
            first,
            last,
        })
    })
}

impl<T: Real> FrequencyData<T> {
    /// The excited lines of `excitation` with output-error noise variances measured on
    /// its noise lines nearby ([`Excitation::noise_lines`]: the noise and distortion lines
    /// of a multisine):
    ///
    /// - at each noise line `j` (`ω_j > 0`) the output error
    ///   `E_j = Y_j − Ĝ_j U_j`, with `Ĝ_j` interpolated linearly in `ω` between
    ///   `Y/U` of the nearest excited lines on each side (the one side at the ends); with
    ///   `U_j ≈ 0` it is the output noise, and it removes the response to what input there
    ///   is;
    /// - at each excited line `k`, `σ̂²_k = (1/m) Σ_j |E_j|²` over the `m = neighbours`
    ///   noise lines nearest to `k` (by line index), returned as output-only variances
    ///   with `variance_dof = m`.
    ///
    /// `σ̂²_k` estimates the variance of `Y_k − G_k U_k` (output noise, input noise seen
    /// through `G` and nonlinear distortion at the unexcited lines) when these vary slowly
    /// over `m` lines.
    ///
    /// # Errors
    /// [`FdidError::TooShort`] named `"unexcited lines"` when fewer than `neighbours` (or no
    /// excited line) exist; [`FdidError::InvalidArgument`] named `"neighbours"` for 0,
    /// `"excitation"` when its length differs from the data's, `"noise"` when a variance
    /// comes out zero or not finite.
    pub fn unexcited_noise(&self, excitation: &Excitation, neighbours: usize) -> Result<Self> {
        let n = self.len();
        if excitation.lines().len() != n {
            return Err(FdidError::InvalidArgument {
                name: "excitation",
                value: excitation.lines().len().to_string(),
                reason: format!("has a flag per line of another data set; these data have {n}"),
            });
        }
        if neighbours == 0 {
            return Err(FdidError::InvalidArgument {
                name: "neighbours",
                value: "0".into(),
                reason: "at least one unexcited line is needed per variance".into(),
            });
        }
        let excited = excitation.lines();
        let w: Vec<f64> = self.omega().iter().map(|v| v.to_f64_lossless()).collect();
        let to64 = |c: &Complex<T>| Complex::new(c.re.to_f64_lossless(), c.im.to_f64_lossless());
        let g: Vec<Complex<f64>> = (0..n)
            .map(|k| to64(&self.y()[k]) / to64(&self.u()[k]))
            .collect();
        let exc: Vec<usize> = (0..n).filter(|&k| excited[k]).collect();
        let noise_lines = excitation.noise_lines();
        let unexc: Vec<usize> = (0..n).filter(|&j| noise_lines[j] && w[j] > 0.0).collect();
        if exc.is_empty() || unexc.len() < neighbours {
            return Err(FdidError::TooShort {
                what: "unexcited lines",
                needed: neighbours.max(1),
                got: if exc.is_empty() { 0 } else { unexc.len() },
            });
        }
        let error: Vec<f64> = unexc
            .iter()
            .map(|&j| {
                let after = exc.partition_point(|&k| k < j);
                let gj = match (after.checked_sub(1).map(|i| exc[i]), exc.get(after)) {
                    (Some(a), Some(&b)) => {
                        let t = (w[j] - w[a]) / (w[b] - w[a]);
                        g[a] * (1.0 - t) + g[b] * t
                    }
                    (Some(a), None) => g[a],
                    (None, Some(&b)) => g[b],
                    (None, None) => unreachable!("exc is not empty"),
                };
                (to64(&self.y()[j]) - gj * to64(&self.u()[j])).norm_sqr()
            })
            .collect();
        let mut var_y = Vec::with_capacity(exc.len());
        for &k in &exc {
            // the `neighbours` unexcited lines nearest to k: a window in `unexc`
            let mut lo = unexc.partition_point(|&j| j < k);
            let mut hi = lo;
            while hi - lo < neighbours {
                let left = (lo > 0).then(|| k - unexc[lo - 1]);
                let right = unexc.get(hi).map(|&j| j - k);
                match (left, right) {
                    (Some(l), Some(r)) if l <= r => lo -= 1,
                    (Some(_), None) => lo -= 1,
                    _ => hi += 1,
                }
            }
            let v = error[lo..hi].iter().sum::<f64>() / neighbours as f64;
            if !(v > 0.0 && v.is_finite()) {
                return Err(FdidError::InvalidArgument {
                    name: "noise",
                    value: format!("{v:e}"),
                    reason: format!(
                        "the unexcited lines near line {k} carry no output error to \
                         estimate the noise from"
                    ),
                });
            }
            var_y.push(T::lit(v));
        }
        self.select_lines(excited)?
            .with_noise(NoiseVariances::output_only(var_y))?
            .with_variance_dof(neighbours)
    }
}

/// The largest drop (dB) in the sorted levels above `floor` with enough lines on each
/// side, and the level just below it, when the drop reaches [`EXCITATION_GAP_DB`].
fn largest_gap(level: &[f64], floor: f64) -> Option<(f64, f64)> {
    let mut sorted: Vec<f64> = level.iter().copied().filter(|l| *l > floor).collect();
    sorted.sort_by(|a, b| b.total_cmp(a));
    let n = sorted.len();
    if n < EXCITATION_GAP_MIN_LINES + 2 {
        return None;
    }
    (2..=n - EXCITATION_GAP_MIN_LINES)
        .map(|i| (20.0 * (sorted[i - 1] / sorted[i]).log10(), sorted[i]))
        .filter(|(gap, _)| *gap >= EXCITATION_GAP_DB)
        .max_by(|a, b| a.0.total_cmp(&b.0))
}

/// Per entry, whether its level lies more than [`EXCITATION_DIP_DB`] below both
/// neighbouring entries with a positive level (the one neighbour at the ends).
fn dips(level: &[f64]) -> Vec<bool> {
    let factor = 10f64.powf(-EXCITATION_DIP_DB / 20.0);
    let n = level.len();
    (0..n)
        .map(|k| {
            let left = (k > 0).then(|| level[k - 1]).filter(|l| *l > 0.0);
            let right = level.get(k + 1).copied().filter(|l| *l > 0.0);
            let reference = match (left, right) {
                (Some(a), Some(b)) => a.min(b),
                (Some(a), None) | (None, Some(a)) => a,
                (None, None) => return false,
            };
            level[k] > 0.0 && level[k] < factor * reference
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex;

    /// Frequency data with U = Y = `u` on the grid 0.01 k rad/s.
    fn data_in<T: Real>(u: &[f64]) -> FrequencyData<T> {
        let omega = (0..u.len()).map(|k| T::lit(0.01 * k as f64)).collect();
        let u: Vec<Complex<T>> = u
            .iter()
            .map(|v| Complex::new(T::lit(*v), T::zero()))
            .collect();
        FrequencyData::new(omega, u.clone(), u, None).unwrap()
    }

    fn data(u: Vec<f64>) -> FrequencyData<f64> {
        data_in(&u)
    }

    /// |U_k| of a complex Gaussian line: Rayleigh, from two uniforms.
    fn rayleigh(state: &mut u64) -> f64 {
        let v = crate::test_rng::lcg(state) + 0.5;
        (-(1.0 - v).ln()).sqrt()
    }

    #[test]
    fn random_input_keeps_every_line() {
        for seed in 1..40u64 {
            let mut state = seed;
            let u: Vec<f64> = (0..1024).map(|_| rayleigh(&mut state)).collect();
            let ex = data(u).excitation(1e-6);
            assert_eq!(ex.rule(), ExcitationRule::Level, "seed {seed}");
            assert_eq!(ex.count(), 1023, "seed {seed}");
        }
    }

    /// Property: an odd multisine over a random band with its even lines and the lines
    /// outside the band at a random noise level 40–100 dB down keeps exactly the designed
    /// lines; a random input of random length and colour keeps every line; in f32 and f64.
    #[test]
    fn designed_lines_exactly_and_random_inputs_whole() {
        fn odd_multisine<T: Real>(seed: u64, first: u8, width: u16, db: u8) -> bool {
            let mut state = seed;
            let n = 1024usize;
            let lo = 1 + 2 * (first as usize % 50);
            let hi = (lo + 40 + 2 * (width as usize % 400)).min(n - 41);
            let noise = 10f64.powf(-(40.0 + (db % 61) as f64) / 20.0);
            let u: Vec<f64> = (0..n)
                .map(|k| {
                    let r = noise * rayleigh(&mut state);
                    if k % 2 == 1 && (lo..=hi).contains(&k) {
                        1.0 + r
                    } else {
                        r
                    }
                })
                .collect();
            let ex = data_in::<T>(&u).excitation(1e-6);
            (0..n).all(|k| ex.lines()[k] == (k % 2 == 1 && (lo..=hi).contains(&k)))
        }
        fn random_input<T: Real>(seed: u64, len: u16, pole: u8) -> bool {
            let mut state = seed;
            let n = 64 + len as usize % 2000;
            // a first-order colouring |1/(1 − a e^{−iω})| with a in [0, 0.95]
            let a = (pole % 96) as f64 / 100.0;
            let u: Vec<f64> = (0..n)
                .map(|k| {
                    let w = std::f64::consts::PI * k as f64 / n as f64;
                    let gain = 1.0 / Complex::new(1.0 - a * w.cos(), a * w.sin()).norm();
                    gain * rayleigh(&mut state)
                })
                .collect();
            let ex = data_in::<T>(&u).excitation(1e-6);
            ex.rule() == ExcitationRule::Level && ex.count() == n - 1
        }
        fn prop(seed: u64, first: u8, width: u16, db: u8) -> bool {
            odd_multisine::<f64>(seed, first, width, db)
                && odd_multisine::<f32>(seed, first, width, db)
                && random_input::<f64>(seed, width, db)
                && random_input::<f32>(seed, width, db)
        }
        quickcheck::QuickCheck::new()
            .rng(quickcheck::Gen::from_size_and_seed(100, 0xe8c1))
            .tests(200)
            .quickcheck(prop as fn(u64, u8, u16, u8) -> bool);
    }

    #[test]
    fn band_limited_multisine_by_gap() {
        let mut state = 3u64;
        let u: Vec<f64> = (0..512)
            .map(|k| {
                let noise = 1e-3 * rayleigh(&mut state);
                if (40..=300).contains(&k) {
                    1.0 + noise
                } else {
                    noise
                }
            })
            .collect();
        let ex = data(u).excitation(1e-6);
        assert!(
            matches!(ex.rule(), ExcitationRule::Gap { gap_db, pattern: None } if gap_db > 40.0)
        );
        assert_eq!(ex.count(), 261);
        assert!(ex.lines()[40] && ex.lines()[300] && !ex.lines()[39] && !ex.lines()[301]);
    }

    #[test]
    fn odd_multisine_with_a_disturbance_line_by_gap_and_pattern() {
        // odd lines 1..=401 excited at 1, a mains-like disturbance on even line 150 at
        // 0.3, the other lines at 1e-3: the disturbance is above the gap but off the grid
        let mut state = 4u64;
        let u: Vec<f64> = (0..1024)
            .map(|k| {
                let noise = 1e-3 * rayleigh(&mut state);
                match k {
                    150 => 0.3,
                    k if k % 2 == 1 && k <= 401 => 1.0 + noise,
                    _ => noise,
                }
            })
            .collect();
        let ex = data(u).excitation(1e-6);
        match ex.rule() {
            ExcitationRule::Gap {
                pattern: Some(p), ..
            } => assert_eq!((p.stride, p.excited_classes), (2, 0b10)),
            other => panic!("{other:?}"),
        }
        assert_eq!(ex.count(), 201);
        assert!(
            !ex.lines()[150] && !ex.noise_lines()[150],
            "the disturbance"
        );
        assert!(ex.noise_lines()[2] && ex.noise_lines()[600]);
        assert!(ex.describe().contains("1 line above the gap off the grid"));
    }

    #[test]
    fn odd_odd_grid_has_stride_four() {
        // lines 4m + 1 excited; 4m + 3 (detection lines) and even lines 30 dB down
        let mut state = 11u64;
        let u: Vec<f64> = (0..600)
            .map(|k| {
                let r = rayleigh(&mut state);
                if k % 4 == 1 && k < 500 {
                    0.5 + 0.5 * r.min(1.0)
                } else {
                    0.03 * r.min(2.0) * if k < 500 { 1.0 } else { 0.1 }
                }
            })
            .collect();
        let ex = data(u).excitation(1e-6);
        match ex.rule() {
            ExcitationRule::Grid {
                pattern: Some(p), ..
            }
            | ExcitationRule::Gap {
                pattern: Some(p), ..
            } => assert_eq!((p.stride, p.excited_classes), (4, 0b10)),
            other => panic!("{other:?}"),
        }
        assert!(
            ex.lines()
                .iter()
                .enumerate()
                .all(|(k, e)| !*e || k % 4 == 1)
        );
        assert!((1..497).step_by(4).all(|k| ex.lines()[k]));
    }

    #[test]
    fn unexcited_lines_measure_the_output_error_variance() {
        // an odd multisine through G = 2/(1 + 0.01 k i) with complex output noise of
        // variance 1e-4 on every line, input leakage 1e-2 on the even lines
        let n = 2048;
        let mut state = 21u64;
        let mut noise = || {
            Complex::new(
                crate::test_rng::lcg(&mut state),
                crate::test_rng::lcg(&mut state),
            ) * (1e-4f64 * 6.0).sqrt()
        };
        let omega: Vec<f64> = (0..n).map(|k| 0.001 * k as f64).collect();
        let g = |k: usize| Complex::new(2.0, 0.0) / Complex::new(1.0, 0.01 * k as f64);
        let u: Vec<Complex<f64>> = (0..n)
            .map(|k| match k {
                0 => Complex::new(0.0, 0.0),
                k if k % 2 == 1 => Complex::from_polar(1.0, 0.7 * k as f64),
                k => Complex::from_polar(1e-2, 1.3 * k as f64),
            })
            .collect();
        let y: Vec<Complex<f64>> = (0..n).map(|k| g(k) * u[k] + noise()).collect();
        let data = FrequencyData::new(omega, y, u, None).unwrap();
        let ex = data.excitation(1e-6);
        let noisy = data.unexcited_noise(&ex, UNEXCITED_NEIGHBOURS).unwrap();
        assert_eq!(noisy.len(), ex.count());
        assert_eq!(noisy.variance_dof(), Some(UNEXCITED_NEIGHBOURS));
        let var = &noisy.noise().unwrap().var_y;
        let mean = var.iter().sum::<f64>() / var.len() as f64;
        // uniform noise of this scale has variance 6e-4 / 12 · 2 = 1e-4 per complex line
        assert!(
            (mean / 1e-4 - 1.0).abs() < 0.1,
            "mean variance {mean:e}, {:?}, {} noise lines, first var {:?}",
            ex.rule(),
            ex.noise_lines().iter().filter(|e| **e).count(),
            &var[..4]
        );
        assert!(data.unexcited_noise(&ex, 0).is_err());
        assert!(data.unexcited_noise(&ex, n).is_err());
    }

    #[test]
    fn swept_odd_excitation_by_grid() {
        // odd lines excited up to line 199 with a level that varies 20 dB and dips a further
        // 20 dB at line 60 (where a measured input has an anti-resonance), even lines 40 dB
        // under their neighbours, and from line 200 only noise 80 dB down whose level falls
        // off smoothly: no single gap separates the classes
        let mut state = 9u64;
        let u: Vec<f64> = (0..512)
            .map(|k| {
                let level = 0.1 + 0.9 * ((k as f64) / 30.0).cos().abs();
                let noise = 1e-4 * (1.0 + (-(k as f64) / 100.0).exp()) * rayleigh(&mut state);
                if k >= 200 {
                    noise
                } else if k % 2 == 1 {
                    let notch = if (59..=61).contains(&k) { 0.1 } else { 1.0 };
                    notch * level + noise
                } else {
                    0.01 * level * rayleigh(&mut state) + noise
                }
            })
            .collect();
        let ex = data(u).excitation(1e-6);
        assert!(
            matches!(ex.rule(), ExcitationRule::Grid { .. }),
            "{:?}",
            ex.rule()
        );
        assert!(
            ex.lines().iter().step_by(2).all(|e| !*e),
            "an even line is excited"
        );
        let odd_in_band = (1..=199).step_by(2).filter(|&k| ex.lines()[k]).count();
        assert_eq!(odd_in_band, 100, "odd lines in the band excited");
        assert!(
            ex.lines()[59] && ex.lines()[61],
            "the odd lines of the notch"
        );
        assert!(
            ex.lines()[205..].iter().all(|e| !*e),
            "a line in the noise tail is excited"
        );
        // the even lines of the band are the noise lines, the notch's included
        let missing: Vec<usize> = (2..=198)
            .step_by(2)
            .filter(|&k| !ex.noise_lines()[k])
            .collect();
        assert!(
            missing.is_empty(),
            "{:?}: even lines {missing:?} are not noise lines",
            ex.rule()
        );
        assert!(!ex.noise_lines()[1] && !ex.noise_lines()[59]);
    }
}
