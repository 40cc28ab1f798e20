//! Tests of `fdid::data::merge`.

use fdid::data::merge;
use fdid::{Complex, FdidError, FrequencyData, NoiseVariances};

fn c(re: f64) -> Complex<f64> {
    Complex::new(re, -re)
}

fn exp(omega: &[f64], tag: f64, ts: Option<f64>) -> FrequencyData<f64> {
    let y = omega.iter().map(|w| c(tag + w)).collect();
    let u = omega.iter().map(|_| c(tag)).collect();
    FrequencyData::new(omega.to_vec(), y, u, ts).unwrap()
}

fn noisy(d: FrequencyData<f64>, tag: f64) -> FrequencyData<f64> {
    let n = d.len();
    d.with_noise(NoiseVariances {
        var_y: vec![tag; n],
        var_u: vec![2.0 * tag; n],
        cov_yu: vec![Complex::new(tag, 0.5); n],
    })
    .unwrap()
}

#[test]
fn interleaves_lines_sorted_and_stable() {
    let a = exp(&[1.0, 3.0, 5.0], 10.0, Some(0.1));
    let b = exp(&[0.5, 3.0, 4.0, 6.0], 20.0, Some(0.1));
    let m = merge(&[a, b]).unwrap();
    assert_eq!(m.omega(), &[0.5, 1.0, 3.0, 3.0, 4.0, 5.0, 6.0]);
    // At ω = 3 the line of the first experiment comes first.
    assert_eq!(m.u()[2], c(10.0));
    assert_eq!(m.u()[3], c(20.0));
    assert_eq!(m.y()[0], c(20.5));
    assert_eq!(m.y()[5], c(15.0));
    assert_eq!(m.ts(), Some(0.1));
    assert!(m.noise().is_none());
}

#[test]
fn single_experiment_is_unchanged() {
    let a = noisy(exp(&[1.0, 2.0], 1.0, Some(0.5)), 3.0);
    assert_eq!(merge(std::slice::from_ref(&a)).unwrap(), a);
}

#[test]
fn different_sample_times_drop_ts() {
    let a = exp(&[1.0], 1.0, Some(0.1));
    let b = exp(&[2.0], 2.0, Some(0.2));
    assert_eq!(merge(&[a.clone(), b]).unwrap().ts(), None);
    let c = exp(&[2.0], 2.0, None);
    assert_eq!(merge(&[a.clone(), c.clone()]).unwrap().ts(), None);
    assert_eq!(merge(&[c, a]).unwrap().ts(), None);
}

#[test]
fn noise_is_merged_line_by_line() {
    let a = noisy(exp(&[1.0, 3.0], 1.0, None), 1.0);
    let b = noisy(exp(&[2.0], 2.0, None), 2.0);
    let m = merge(&[a, b]).unwrap();
    let n = m.noise().unwrap();
    assert_eq!(n.var_y, vec![1.0, 2.0, 1.0]);
    assert_eq!(n.var_u, vec![2.0, 4.0, 2.0]);
    assert_eq!(
        n.cov_yu,
        vec![
            Complex::new(1.0, 0.5),
            Complex::new(2.0, 0.5),
            Complex::new(1.0, 0.5)
        ]
    );
    assert_eq!(m.omega(), &[1.0, 2.0, 3.0]);
}

#[test]
fn partial_noise_is_an_error() {
    let a = noisy(exp(&[1.0], 1.0, None), 1.0);
    let b = exp(&[2.0], 2.0, None);
    let e = merge(&[a, b]).unwrap_err();
    match &e {
        FdidError::InvalidArgument { name, value, .. } => {
            assert_eq!(*name, "experiments");
            assert!(value.contains("experiment 1"), "{value}");
        }
        other => panic!("unexpected {other:?}"),
    }
}

#[test]
fn empty_slice_is_too_short() {
    let e = merge::<f64>(&[]).unwrap_err();
    assert_eq!(
        e,
        FdidError::TooShort {
            what: "experiments",
            needed: 1,
            got: 0
        }
    );
}

#[test]
fn merges_f32_and_result_is_valid() {
    let a = FrequencyData::<f32>::from_frf(
        vec![0.0, 2.0],
        vec![Complex::new(1.0, 0.0), Complex::new(0.5, 0.5)],
        None,
    )
    .unwrap();
    let b = FrequencyData::<f32>::from_frf(vec![1.0], vec![Complex::new(0.7, 0.1)], None).unwrap();
    let m = merge(&[a, b]).unwrap();
    assert_eq!(m.omega(), &[0.0f32, 1.0, 2.0]);
    // The merged data pass the validating constructor.
    let again = FrequencyData::new(m.omega().to_vec(), m.y().to_vec(), m.u().to_vec(), m.ts());
    assert_eq!(again.unwrap(), m);
}

#[test]
fn merge_of_dfts_of_two_records() {
    use fdid::TimeData;
    let r1 = TimeData::new(vec![1.0, 0.0, -1.0, 0.0], vec![0.0, 1.0, 0.0, -1.0], 1.0).unwrap();
    let r2 = TimeData::new(vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0], vec![0.0; 6], 1.0).unwrap();
    let m = merge(&[r1.dft(), r2.dft()]).unwrap();
    assert_eq!(m.len(), 3 + 4);
    assert_eq!(m.ts(), Some(1.0));
    assert!(m.omega().windows(2).all(|w| w[0] <= w[1]));
}
