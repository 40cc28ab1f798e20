//! Which vector instructions the kernels chosen at run time use: the processor's best
//! ([`SimdPath::detected`]), or one forced by the environment variable `FDID_SIMD`
//! (`scalar`, `avx2` or `avx512`, read once) or by [`force`], as a testing aid.
//!
//! Every path gives the same result bit for bit (see [`crate::linalg`], "One answer on
//! every processor"): the switch exists so that one machine can run the kernels, the
//! pipeline and the workflow on each path it has and compare them, not to trade accuracy
//! for speed.
//!
//! ```
//! use fdid::linalg::simd::{self, SimdPath};
//!
//! // the scalar path runs on every processor
//! assert!(SimdPath::Scalar.is_supported());
//! let before = simd::active();
//! simd::force(Some(SimdPath::Scalar)).unwrap();
//! assert_eq!(simd::active(), SimdPath::Scalar);
//! simd::force(None).unwrap(); // back to FDID_SIMD or the processor's best
//! assert_eq!(simd::active(), before);
//! ```

use crate::error::{FdidError, Result};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU8, Ordering};

/// A set of vector instructions that the run-time kernels can use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SimdPath {
    /// No vector instructions: plain arithmetic (fused multiply-adds through `mul_add`).
    Scalar,
    /// x86-64 AVX2 with FMA: 256-bit registers.
    Avx2,
    /// x86-64 AVX-512 (the foundation, `avx512f`): 512-bit registers.
    Avx512,
}

impl SimdPath {
    /// Every path, from the plainest.
    pub const ALL: [SimdPath; 3] = [SimdPath::Scalar, SimdPath::Avx2, SimdPath::Avx512];

    /// The name used by `FDID_SIMD`: `scalar`, `avx2` or `avx512`.
    pub fn name(self) -> &'static str {
        match self {
            SimdPath::Scalar => "scalar",
            SimdPath::Avx2 => "avx2",
            SimdPath::Avx512 => "avx512",
        }
    }

    /// The path named `name` (as [`SimdPath::name`], any case, surrounding blanks ignored).
    pub fn parse(name: &str) -> Result<Self> {
        let wanted = name.trim();
        SimdPath::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(wanted))
            .ok_or_else(|| FdidError::InvalidArgument {
                name: "FDID_SIMD",
                value: format!("{name:?}"),
                reason: "not a SIMD path: use scalar, avx2 or avx512".into(),
            })
    }

    /// True when this processor can run the path.
    pub fn is_supported(self) -> bool {
        match self {
            SimdPath::Scalar => true,
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
            }
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx512 => {
                std::arch::is_x86_feature_detected!("avx512f") && SimdPath::Avx2.is_supported()
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The paths this processor can run, from the plainest.
    pub fn supported() -> Vec<SimdPath> {
        SimdPath::ALL
            .into_iter()
            .filter(|p| p.is_supported())
            .collect()
    }

    /// The widest path this processor can run.
    pub fn detected() -> SimdPath {
        SimdPath::ALL
            .into_iter()
            .rev()
            .find(|p| p.is_supported())
            .unwrap_or(SimdPath::Scalar)
    }

    fn code(self) -> u8 {
        self as u8 + 1
    }

    fn from_code(code: u8) -> Option<SimdPath> {
        SimdPath::ALL
            .get(usize::from(code).checked_sub(1)?)
            .copied()
    }
}

impl std::fmt::Display for SimdPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The path forced by [`force`] (0: none).
static FORCED: AtomicU8 = AtomicU8::new(0);

/// The path of the environment (`FDID_SIMD`, read once) or else the processor's best.
fn default_path() -> SimdPath {
    static DEFAULT: OnceLock<SimdPath> = OnceLock::new();
    *DEFAULT.get_or_init(|| {
        let Some(value) = std::env::var_os("FDID_SIMD") else {
            return SimdPath::detected();
        };
        let best = SimdPath::detected();
        match value.to_str().map(SimdPath::parse) {
            Some(Ok(path)) if path.is_supported() => path,
            Some(Ok(path)) => {
                eprintln!("fdid: FDID_SIMD={path}: this processor cannot run it; using {best}");
                best
            }
            _ => {
                eprintln!("fdid: FDID_SIMD={value:?} is not scalar, avx2 or avx512; using {best}");
                best
            }
        }
    })
}

/// The path the kernels use now: the one [`force`]d, else `FDID_SIMD`'s, else the
/// processor's best.
#[inline]
pub fn active() -> SimdPath {
    SimdPath::from_code(FORCED.load(Ordering::Relaxed)).unwrap_or_else(default_path)
}

/// Forces `path` on every thread of the process (`None`: back to `FDID_SIMD` or the
/// processor's best); an error naming the path when this processor cannot run it. A
/// testing aid: since every path gives the same results, switching while other threads
/// compute changes their speed, never their results.
pub fn force(path: Option<SimdPath>) -> Result<()> {
    match path {
        Some(p) if !p.is_supported() => Err(FdidError::InvalidArgument {
            name: "SIMD path",
            value: p.name().into(),
            reason: format!(
                "this processor cannot run it (it runs {})",
                SimdPath::supported()
                    .iter()
                    .map(|p| p.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }),
        _ => {
            FORCED.store(path.map_or(0, SimdPath::code), Ordering::Relaxed);
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_names_are_refused() {
        for p in SimdPath::ALL {
            assert_eq!(SimdPath::parse(p.name()).unwrap(), p);
            assert_eq!(SimdPath::parse(&p.name().to_uppercase()).unwrap(), p);
            assert_eq!(SimdPath::from_code(p.code()), Some(p));
        }
        let err = SimdPath::parse("sse9").unwrap_err().to_string();
        assert!(err.contains("\"sse9\"") && err.contains("avx512"), "{err}");
        assert_eq!(SimdPath::from_code(0), None);
    }

    #[test]
    fn the_detected_path_is_supported_and_scalar_always_is() {
        assert!(SimdPath::detected().is_supported());
        assert!(SimdPath::supported().contains(&SimdPath::Scalar));
        assert!(SimdPath::supported().contains(&SimdPath::detected()));
        for p in SimdPath::ALL {
            if !p.is_supported() {
                assert!(force(Some(p)).unwrap_err().to_string().contains(p.name()));
            }
        }
    }
}
