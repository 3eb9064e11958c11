//! The convergence analysis' building blocks checked against what they stand for:
//! `q_gain_sq` against the frequency response of the filter `learning.rs` designs and
//! applies, and `validate` against each setting it must refuse.

use ckcm::convergence::{ConvergenceError, q_gain_sq, validate};
use ckcm::learning::{LowPass, MAX_ORDER, UpdateSettings, butter_lowpass};

/// |b(z) / a(z)|² at z = e^{jωh}, summed term by term.
fn response_sq(b: &[f64], a: &[f64], f: f64, h: f64) -> f64 {
    let w = 2.0 * std::f64::consts::PI * f * h;
    let at = |c: &[f64]| {
        let (re, im) = c.iter().enumerate().fold((0.0, 0.0), |(re, im), (k, x)| {
            let phase = -(k as f64) * w;
            (re + x * phase.cos(), im + x * phase.sin())
        });
        re * re + im * im
    };
    at(b) / at(a)
}

/// The closed form |Q|² = 1 / (1 + (tan(πfh) / tan(πf_c h))^{2N}) is the squared magnitude of
/// the designed Butterworth filter, for every order and across the band.
#[test]
fn q_gain_is_the_designed_filters_squared_magnitude() {
    let h = 1e-3;
    for order in 1..=MAX_ORDER {
        for cutoff_hz in [5.0, 20.0, 150.0] {
            let tf = butter_lowpass(order, cutoff_hz, 1.0 / h).unwrap();
            let q = LowPass { order, cutoff_hz };
            // The numerator/denominator form loses about a digit per order at low
            // normalised cutoffs (learning::MAX_ORDER): its gain at 0 Hz, 1 in exact
            // arithmetic, measures what it lost (0.8 % for order 8 at 5 Hz). Summing the
            // response near z = 1, where a(z) nearly cancels, costs up to about 1e-7 more.
            let lost = (1.0 - response_sq(&tf.b, &tf.a, 0.0, h)).abs();
            for f in [
                0.0,
                1.0,
                0.5 * cutoff_hz,
                cutoff_hz,
                1.5 * cutoff_hz,
                2.0 * cutoff_hz,
            ] {
                let closed = q_gain_sq(&q, f, h);
                let designed = response_sq(&tf.b, &tf.a, f, h);
                assert!(
                    (closed - designed).abs() <= 2.0 * lost + 1e-6,
                    "order {order}, cutoff {cutoff_hz} Hz, f {f} Hz: closed form {closed}, \
                     designed filter {designed}"
                );
            }
        }
    }
    let q = LowPass {
        order: 2,
        cutoff_hz: 20.0,
    };
    assert_eq!(q_gain_sq(&q, 0.0, h), 1.0);
    assert!((q_gain_sq(&q, 20.0, h) - 0.5).abs() < 1e-15);
}

/// Each setting the analysis cannot use is refused under its own name.
#[test]
fn validate_names_the_setting_it_refuses() {
    let h = 1e-3;
    let filtered = |order, cutoff_hz| UpdateSettings {
        filter: Some(LowPass { order, cutoff_hz }),
        ..UpdateSettings::default()
    };
    let refused = |update: &UpdateSettings, h: f64| match validate(update, h) {
        Err(ConvergenceError::Invalid { name, .. }) => name,
        other => panic!("{update:?} at h = {h}: {other:?}"),
    };
    assert_eq!(validate(&UpdateSettings::default(), h), Ok(()));
    assert_eq!(validate(&filtered(1, 1.0), h), Ok(()));
    assert_eq!(validate(&filtered(MAX_ORDER, 499.0), h), Ok(()));
    for bad_h in [0.0, -1e-3, f64::NAN, f64::INFINITY] {
        assert_eq!(refused(&UpdateSettings::default(), bad_h), "h");
    }
    let forgetting = UpdateSettings {
        forgetting: f64::NAN,
        ..UpdateSettings::default()
    };
    assert_eq!(refused(&forgetting, h), "forgetting");
    let gain = UpdateSettings {
        gain: f64::INFINITY,
        ..UpdateSettings::default()
    };
    assert_eq!(refused(&gain, h), "gain");
    assert_eq!(refused(&filtered(0, 20.0), h), "order");
    assert_eq!(refused(&filtered(MAX_ORDER + 1, 20.0), h), "order");
    for cutoff in [0.0, -5.0, 500.0, 600.0, f64::NAN] {
        assert_eq!(refused(&filtered(2, cutoff), h), "cutoff");
    }
}
