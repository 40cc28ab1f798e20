//! Large buffers a thread keeps from one fit to the next.
//!
//! A fit allocates buffers of tens of kilobytes (basis tables, blocks of stacked rows, the
//! solver's residual vectors), frees them at its end, and the next fit allocates them
//! again. The system allocator returns memory freed at the top of its heap to the operating
//! system once more than a threshold lies free there (glibc: 128 KiB by default), so that
//! each fit of a loop faults its pages in again — some 36 page faults, about a tenth of an
//! order-4 fit of 2 000 lines on a virtual machine, and a fifth of a fit of 200 000 lines.
//! The crate's large work buffers are therefore given back to the calling thread's shelf
//! when freed, up to [`MAX_KEPT_BYTES`] (64 MiB, what glibc itself leaves untrimmed once
//! its thresholds have adapted to large blocks) and 32 buffers a thread, and the next
//! allocation of that type takes the smallest kept buffer large enough (and not more than
//! twice as large, so that a small request leaves a large buffer to the large request
//! that follows it). [`release`] frees the calling thread's buffers, and a thread's are
//! freed when it ends.
//!
//! ```
//! use fdid::prelude::*;
//!
//! // 2 000 lines of G(s) = 1 / (s + 1)
//! let omega: Vec<f64> = (1..=2_000).map(|k| 0.005 * k as f64).collect();
//! let frf = omega.iter().map(|w| Complex::new(1.0, *w).inv()).collect();
//! let data = FrequencyData::from_frf(omega, frf, None).unwrap();
//! let model = Rational::continuous(1, 0, data.omega()).unwrap();
//! let fit = Pipeline::default().fit(&model, &data).unwrap();
//! assert!((fit.poles().unwrap()[0] + 1.0).norm() < 1e-9);
//! // the fit's work buffers stay with this thread for the next fit, until released
//! assert!(fdid::recycle::kept_bytes() > 0);
//! fdid::recycle::release();
//! assert_eq!(fdid::recycle::kept_bytes(), 0);
//! ```

use std::any::Any;
use std::cell::RefCell;

/// The smallest buffer worth keeping, in bytes: smaller ones are served from the
/// allocator's bins without touching the heap's top.
pub const MIN_BYTES: usize = 4 << 10;

/// The most bytes a thread keeps.
pub const MAX_KEPT_BYTES: usize = 64 << 20;

/// The most buffers a thread keeps.
const MAX_KEPT: usize = 32;

thread_local! {
    /// The kept buffers, each with its size in bytes.
    static SHELF: RefCell<Vec<(usize, Box<dyn Any>)>> = const { RefCell::new(Vec::new()) };
}

/// `len` copies of `value`, in the smallest kept buffer of this thread with room for
/// them (and for at most twice as many, see [`MAX_SLACK`]), else in a new one.
pub(crate) fn filled<E: Copy + 'static>(len: usize, value: E) -> Vec<E> {
    if len.saturating_mul(size_of::<E>()) >= MIN_BYTES
        && let Some(mut v) = take::<E>(len)
    {
        v.clear();
        v.resize(len, value);
        return v;
    }
    vec![value; len]
}

/// Gives `v` to this thread's shelf for a later [`filled`]; dropped instead when it is
/// smaller than [`MIN_BYTES`], or the shelf would hold more than [`MAX_KEPT_BYTES`] or
/// [`MAX_KEPT`] buffers.
pub(crate) fn keep<E: 'static>(v: Vec<E>) {
    let bytes = v.capacity().saturating_mul(size_of::<E>());
    if !(MIN_BYTES..=MAX_KEPT_BYTES).contains(&bytes) {
        return;
    }
    // (a thread being torn down, or a shelf in use, just drops the buffer)
    let _ = SHELF.try_with(|shelf| {
        if let Ok(mut shelf) = shelf.try_borrow_mut()
            && shelf.len() < MAX_KEPT
            && bytes_on(&shelf) + bytes <= MAX_KEPT_BYTES
        {
            shelf.push((bytes, Box::new(v)));
        }
    });
}

/// A vector from [`filled`] that goes back to the shelf ([`keep`]) when dropped, for a
/// buffer that lives through one call with many ways out.
pub(crate) struct Kept<E: 'static>(Vec<E>);

impl<E: Copy + 'static> Kept<E> {
    /// `len` copies of `value` ([`filled`]).
    pub(crate) fn filled(len: usize, value: E) -> Self {
        Self(filled(len, value))
    }
}

impl<E: 'static> std::ops::Deref for Kept<E> {
    type Target = Vec<E>;
    fn deref(&self) -> &Vec<E> {
        &self.0
    }
}

impl<E: 'static> std::ops::DerefMut for Kept<E> {
    fn deref_mut(&mut self) -> &mut Vec<E> {
        &mut self.0
    }
}

impl<E: 'static> Drop for Kept<E> {
    fn drop(&mut self) {
        keep(std::mem::take(&mut self.0));
    }
}

/// `v` as `len` copies of `value`: its buffer given to the shelf ([`keep`]) and the
/// vector taken again by [`filled`].
pub(crate) fn refill_vec<E: Copy + 'static>(v: &mut Vec<E>, len: usize, value: E) {
    keep(std::mem::take(v));
    *v = filled(len, value);
}

/// A matrix of `Dyn` rows whose buffer the shelf can take.
type Owned<E, C> = nalgebra::Matrix<E, nalgebra::Dyn, C, nalgebra::VecStorage<E, nalgebra::Dyn, C>>;

/// `m` as `rows` × `cols` copies of `value`: its buffer given to the shelf ([`keep`]) and
/// the matrix's taken by [`filled`].
pub(crate) fn refill<E: nalgebra::Scalar + Copy, C: nalgebra::Dim>(
    m: &mut Owned<E, C>,
    rows: usize,
    cols: usize,
    value: E,
) {
    keep_matrix(m);
    let values = filled(rows * cols, value);
    let storage = nalgebra::VecStorage::new(nalgebra::Dyn(rows), C::from_usize(cols), values);
    *m = Owned::from_data(storage);
}

/// Gives the buffer of `m` to the shelf ([`keep`]), leaving an empty matrix.
pub(crate) fn keep_matrix<E: nalgebra::Scalar, C: nalgebra::Dim>(m: &mut Owned<E, C>) {
    let (_, cols) = m.shape_generic();
    let empty = nalgebra::VecStorage::new(nalgebra::Dyn(0), cols, Vec::new());
    let storage = std::mem::replace(&mut m.data, empty);
    keep(Vec::from(storage));
}

/// The bytes of the buffers on `shelf`.
fn bytes_on(shelf: &[(usize, Box<dyn Any>)]) -> usize {
    shelf.iter().map(|(b, _)| *b).sum()
}

/// A kept buffer serves a request for at least 1/`MAX_SLACK` of its values: a smaller one
/// would take a large buffer (a long record's basis table) that the same fit asks for
/// again later, and that then has to be allocated afresh, page by page (measured on
/// order-4 fits of 20 000 lines: some 400 page faults a fit, about 1.5 ms, before this
/// bound).
const MAX_SLACK: usize = 2;

/// The smallest kept `Vec<E>` with room for `len` values and at most [`MAX_SLACK`] times
/// as many, off the shelf.
fn take<E: 'static>(len: usize) -> Option<Vec<E>> {
    SHELF
        .try_with(|shelf| {
            let mut shelf = shelf.try_borrow_mut().ok()?;
            let (i, _) = shelf
                .iter()
                .enumerate()
                .filter_map(|(i, (_, b))| {
                    let v = b.downcast_ref::<Vec<E>>()?;
                    (len..=len.saturating_mul(MAX_SLACK))
                        .contains(&v.capacity())
                        .then_some((i, v.capacity()))
                })
                .min_by_key(|(_, cap)| *cap)?;
            let (_, b) = shelf.swap_remove(i);
            b.downcast::<Vec<E>>().ok().map(|v| *v)
        })
        .ok()
        .flatten()
}

/// Frees the buffers the calling thread keeps (for example after fitting a long record,
/// when no fit of its size follows).
pub fn release() {
    let _ = SHELF.try_with(|shelf| {
        if let Ok(mut shelf) = shelf.try_borrow_mut() {
            *shelf = Vec::new();
        }
    });
}

/// The bytes of the buffers the calling thread keeps.
pub fn kept_bytes() -> usize {
    held().1
}

/// The number of buffers and bytes this thread keeps (none while the shelf is in use).
fn held() -> (usize, usize) {
    SHELF
        .try_with(|s| s.try_borrow().map_or((0, 0), |s| (s.len(), bytes_on(&s))))
        .unwrap_or((0, 0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scalar::Complex;

    #[test]
    fn kept_buffers_are_reused_by_type_and_size_and_bounded() {
        // each test runs on its own thread: the shelf starts empty
        assert_eq!(held(), (0, 0));
        let big = filled(1000, 1.5f64);
        assert_eq!((big.len(), big[999]), (1000, 1.5));
        let at = big.as_ptr();
        keep(big);
        assert_eq!(held(), (1, 8000));
        // another type does not take it; a longer vector does not fit in it
        let c = filled(600, Complex::new(0.0f64, 1.0));
        assert_eq!(held().0, 1);
        let longer = filled(1001, 0.0f64);
        assert_eq!(held().0, 1);
        // the same type of no more values takes it, refilled
        let again = filled(700, 2.0f64);
        assert_eq!(again.as_ptr(), at);
        assert!(again.iter().all(|v| *v == 2.0) && again.len() == 700);
        assert_eq!(held(), (0, 0));
        // the smallest buffer with room is taken
        keep(longer);
        keep(again);
        keep(c);
        let small = filled(800, 0.0f64);
        assert_eq!(small.capacity(), 1000);
        keep(small);
        // a request for less than half a buffer leaves it on the shelf for a larger one
        let half = filled(499, 0.0f64);
        assert_eq!((half.capacity(), held().0), (499, 3));
        let large = filled(600, 0.0f64);
        assert_eq!((large.capacity(), held().0), (1000, 2));
        keep(large);
        // small buffers are not kept; nor beyond the byte budget
        keep(vec![0u8; MIN_BYTES - 1]);
        assert_eq!(held().0, 3);
        keep(vec![0u8; MAX_KEPT_BYTES]);
        assert_eq!(held().0, 3);
        keep(vec![0u8; MAX_KEPT_BYTES + 1]);
        assert_eq!(held().0, 3);
        // small requests never read the shelf
        let tiny = filled(3, 0.0f64);
        assert_eq!((tiny.capacity(), held().0), (3, 3));
        // at most MAX_KEPT buffers
        for _ in 0..2 * MAX_KEPT {
            keep(vec![0u8; MIN_BYTES]);
        }
        assert_eq!(held().0, MAX_KEPT);
        assert!(kept_bytes() >= MAX_KEPT * MIN_BYTES);
        release();
        // matrices and vectors refilled in a new shape, their old buffer reused
        let mut m = nalgebra::DMatrix::from_element(40, 30, 1.0f64);
        let at = m.as_ptr();
        refill(&mut m, 30, 20, 2.0);
        assert_eq!((m.shape(), m.as_ptr(), m[(29, 19)]), ((30, 20), at, 2.0));
        let mut v = nalgebra::DVector::from_element(700, 1.0f64);
        refill(&mut v, 600, 1, 3.0);
        assert!(v.len() == 600 && v.iter().all(|x| *x == 3.0));
        let mut w = vec![Complex::new(1.0f64, 0.0); 300];
        refill_vec(&mut w, 290, Complex::new(0.0, 1.0));
        assert!(w.len() == 290 && w.iter().all(|x| x.im == 1.0));
        keep_matrix(&mut v);
        assert_eq!((v.len(), held().0), (0, 1));
        release();
        assert_eq!((held(), kept_bytes()), ((0, 0), 0));
    }

    /// Any sequence of requests and returns, of both precisions and of real and complex
    /// values: each vector has the length and values asked for, and the shelf stays within
    /// its bounds.
    #[test]
    fn a_kept_vector_goes_back_to_the_shelf_when_dropped() {
        assert_eq!(held(), (0, 0));
        let mut r = Kept::filled(1_000, 2.0f64);
        assert!(r.iter().all(|v| *v == 2.0) && r.len() == 1_000);
        r[3] = 5.0;
        let address = r.as_ptr();
        drop(r);
        assert_eq!(held().0, 1);
        // the next one takes that buffer, with the values asked for
        let again = Kept::filled(900, 0.0f64);
        assert_eq!((again.as_ptr(), again.len()), (address, 900));
        assert!(again.iter().all(|v| *v == 0.0));
        assert_eq!(held().0, 0);
    }

    #[test]
    fn any_use_of_the_shelf_gives_the_values_asked_for() {
        fn check<E: Copy + PartialEq + 'static>(len: usize, value: E) -> Option<Vec<E>> {
            let v = filled(len, value);
            (v.len() == len && v.iter().all(|x| *x == value)).then_some(v)
        }
        fn prop(steps: Vec<(u8, u16, bool)>) -> bool {
            release();
            let mut out: Vec<Box<dyn Any>> = vec![];
            for (kind, len, give_back) in steps {
                // up to 65 535 values: some below the 4 KiB floor, most above
                let (len, x) = (usize::from(len), f64::from(len));
                let v: Option<Box<dyn Any>> = match kind % 4 {
                    0 => check(len, x).map(|v| Box::new(v) as Box<dyn Any>),
                    1 => check(len, x as f32).map(|v| Box::new(v) as Box<dyn Any>),
                    2 => check(len, Complex::new(x, -x)).map(|v| Box::new(v) as Box<dyn Any>),
                    _ => check(len, Complex::new(x as f32, 1.0)).map(|v| Box::new(v) as _),
                };
                let Some(v) = v else { return false };
                if give_back {
                    match kind % 4 {
                        0 => keep(*v.downcast::<Vec<f64>>().unwrap()),
                        1 => keep(*v.downcast::<Vec<f32>>().unwrap()),
                        2 => keep(*v.downcast::<Vec<Complex<f64>>>().unwrap()),
                        _ => keep(*v.downcast::<Vec<Complex<f32>>>().unwrap()),
                    }
                } else {
                    out.push(v);
                }
                let (count, bytes) = held();
                if count > MAX_KEPT || bytes > MAX_KEPT_BYTES {
                    return false;
                }
            }
            release();
            true
        }
        quickcheck::QuickCheck::new()
            .tests(300)
            .rng(quickcheck::Gen::from_size_and_seed(40, 0x5eed))
            .quickcheck(prop as fn(Vec<(u8, u16, bool)>) -> bool);
    }
}
