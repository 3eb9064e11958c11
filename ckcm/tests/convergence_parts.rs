//! The convergence analysis' building blocks checked against what they stand for:
//! `q_gain_sq` against the frequency response of the filter `learning.rs` designs and
//! applies, `validate` against each setting it must refuse, and the grids, spreads and
//! bands the report is built from against values worked out by hand.

use ckcm::convergence::{
    ConvergenceError, ModeSpread, bands_above_one, frequency_grid, mass_grid, mass_history,
    max_safe_cutoff, mode_spread, q_gain_sq, validate,
};
use ckcm::learning::{LowPass, MAX_ORDER, UpdateSettings, butter_lowpass};
use ckcm::{Mechanism, Params, Trajectory};

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
            // response near z = 1, where a(z) nearly cancels, loses digits of its own: hence
            // the 1e-6 on top.
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

/// Even steps over a mode's mass range, ends included; logarithmic steps from `f_min` to just
/// below Nyquist.
#[test]
fn grids_span_their_ranges_in_even_steps() {
    let spread = ModeSpread {
        min: 2.0,
        max: 8.0,
        time_of_max: 0.0,
        pose_of_max: [0.0; 6],
    };
    assert_eq!(mass_grid(&spread, 4), vec![2.0, 4.0, 6.0, 8.0]);
    assert_eq!(mass_grid(&spread, 1), vec![2.0, 8.0]);
    let f = frequency_grid(1e-3, 1.0, 5);
    let top = 500.0 * (1.0 - 1e-6);
    assert_eq!(f.len(), 5);
    assert_eq!(f[0], 1.0);
    assert!((f[4] / top - 1.0).abs() < 1e-12, "{f:?}");
    for w in f.windows(2) {
        let ratio = w[1] / w[0];
        assert!((ratio / top.powf(0.25) - 1.0).abs() < 1e-12, "{f:?}");
    }
}

/// Each mode's lightest and heaviest mass over a history, with the time and pose of the
/// first sample where the heaviest occurs.
#[test]
fn a_modes_spread_keeps_its_first_heaviest_sample() {
    let line = Trajectory::line(0.5);
    let history = [
        (0.0, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
        (0.5, [1.5, 2.0, 2.5, 4.0, 5.0, 7.0]),
        (1.0, [0.5, 2.0, 3.0, 4.0, 6.0, 7.0]),
    ];
    let s = mode_spread(&history, &line);
    assert_eq!(s[0].min, 0.5);
    assert_eq!(s[0].max, 1.5);
    assert_eq!(s[0].time_of_max, 0.5);
    assert_eq!(s[0].pose_of_max, line.sample(0.5).pose.to_xyz_euler());
    // Equal at every sample: the first.
    assert_eq!((s[1].min, s[1].max, s[1].time_of_max), (2.0, 2.0, 0.0));
    assert_eq!(s[5].time_of_max, 0.5);
    assert_eq!(s[4].time_of_max, 1.0);
}

/// A factor above 1 on (10, 20) Hz only: one band, its edges refined to 1e-6 between the
/// grid's points; a band reaching the grid's end ends there.
#[test]
fn bands_above_one_are_found_and_their_edges_refined() {
    let grid: Vec<f64> = (1..=100).map(|i| i as f64 * 1.5).collect();
    let step = |f: f64| if f > 10.0 && f < 20.0 { 2.0 } else { 0.5 };
    let bands = bands_above_one(&grid, step);
    assert_eq!(bands.len(), 1, "{bands:?}");
    let (lo, hi) = bands[0];
    assert!((lo / 10.0 - 1.0).abs() < 2e-6 && lo > 10.0, "{bands:?}");
    assert!((hi / 20.0 - 1.0).abs() < 2e-6 && hi < 20.0, "{bands:?}");
    let tail = bands_above_one(&grid, |f| if f > 100.0 { 2.0 } else { 0.5 });
    assert_eq!(tail.len(), 1);
    assert!((tail[0].0 / 100.0 - 1.0).abs() < 2e-6);
    assert_eq!(tail[0].1, 150.0);
    // A factor of exactly 1 neither grows nor shrinks the memory: not above one.
    let at_one = |f: f64| if f > 10.0 && f < 20.0 { 2.0 } else { 1.0 };
    assert_eq!(bands_above_one(&grid, at_one), bands);
    // Edges refined relative to their frequency, below 1 Hz as well.
    let low: Vec<f64> = grid.iter().map(|f| f / 100.0).collect();
    let low_bands = bands_above_one(&low, |f| step(f * 100.0));
    assert_eq!(low_bands.len(), 1, "{low_bands:?}");
    assert!((low_bands[0].0 / 0.1 - 1.0).abs() < 2e-6, "{low_bands:?}");
    assert!((low_bands[0].1 / 0.2 - 1.0).abs() < 2e-6, "{low_bands:?}");
    assert!(bands_above_one(&grid, |_| 0.5).is_empty());
    assert_eq!(bands_above_one(&grid, |_| 2.0), vec![(1.5, 150.0)]);
}

/// A stride that is not positive is refused as such, before its pose count is.
#[test]
fn a_stride_that_is_not_positive_is_refused_as_such() {
    let m = Mechanism::new(Params::default()).unwrap();
    for stride in [0.0, -0.005] {
        match mass_history(&m, &Trajectory::line(0.5), stride) {
            Err(ConvergenceError::Invalid { name, reason, .. }) => {
                assert_eq!((name, reason), ("stride", "must be positive"));
            }
            other => panic!("stride {stride}: {other:?}"),
        }
    }
}

/// The frequency response L P of one mode's sampled loop against the loop itself, stepped in
/// time: a cosine learning input u, after the transients have died, gives a learning output
/// Δ = −L P u (Δ = Φ e + Ψ I + Γ ė with e = −x, the running sum I including the sample,
/// the force held over the step). Gains well away from Table 1's, so that every term,
/// the integral's included, shows at the test frequencies.
#[test]
fn learning_response_is_the_stepped_loops_response() {
    use ckcm::control::Gains;
    use ckcm::convergence::ModeLoop;
    let gains = Gains {
        kp: 1e4,
        ki: 1e5,
        kd: 100.0,
        phi: 1.0,
        gamma: 0.1,
        psi: 10.0,
    };
    let mode = ModeLoop {
        mass: 10.0,
        viscous: 100.0,
        gains,
        h: 1e-3,
    };
    let (m, b, h) = (mode.mass, mode.viscous, mode.h);
    for f in [2.0, 25.0, 160.0] {
        let w = std::f64::consts::TAU * f;
        // Exact zero-order-hold step of m ẍ + b ẋ = force.
        let a = b / m;
        let p = (-a * h).exp();
        let (c1, c3) = ((1.0 - p) / a, (1.0 - p) / b);
        let c2 = (h - c1) / b;
        let (mut x, mut v, mut integral) = (0.0_f64, 0.0_f64, 0.0_f64);
        let steps = 20_000;
        // The last second: a whole number of periods at each test frequency.
        let window = 1_000;
        let (mut u_hat, mut d_hat) = ((0.0, 0.0), (0.0, 0.0));
        for n in 0..steps {
            let t = n as f64 * h;
            let u = (w * t).cos();
            let (e, ed) = (-x, -v);
            integral += h * e;
            let force = gains.kp * e + gains.ki * integral + gains.kd * ed + u;
            let delta = gains.phi * e + gains.psi * integral + gains.gamma * ed;
            if n >= steps - window {
                let (c, s) = ((w * t).cos(), -(w * t).sin());
                u_hat = (u_hat.0 + u * c, u_hat.1 + u * s);
                d_hat = (d_hat.0 + delta * c, d_hat.1 + delta * s);
            }
            (x, v) = (x + c1 * v + c2 * force, p * v + c3 * force);
        }
        // −Δ̂ / û, as a complex quotient.
        let den = u_hat.0 * u_hat.0 + u_hat.1 * u_hat.1;
        let re = -(d_hat.0 * u_hat.0 + d_hat.1 * u_hat.1) / den;
        let im = -(d_hat.1 * u_hat.0 - d_hat.0 * u_hat.1) / den;
        let lp = mode.learning_response(f);
        let err = ((lp.re - re).powi(2) + (lp.im - im).powi(2)).sqrt() / lp.norm();
        assert!(
            err < 1e-9,
            "{f} Hz: L P = {lp}, stepped loop {re} + {im}i (relative difference {err:e})"
        );
    }
}

/// An envelope of 4 at 100 Hz and 0.5 elsewhere: a cutoff is safe while |Q(100 Hz)|² ≤ 1/4,
/// that is tan(π f_c h) ≤ tan(π 100 h) / 3^{1/(2N)}; the search finds that cutoff to its
/// 1e-4 from below. An envelope above 2 at the grid's first frequency leaves no safe
/// cutoff; one nowhere above 1 needs no filter (Nyquist).
#[test]
fn the_safe_cutoff_is_found_where_the_filter_just_holds_the_envelope() {
    let h = 1e-3;
    let grid = frequency_grid(h, 0.1, 400);
    let spike = |f0: f64, height: f64| -> Vec<f64> {
        let i = grid
            .iter()
            .enumerate()
            .min_by(|a, b| (a.1 - f0).abs().total_cmp(&(b.1 - f0).abs()))
            .unwrap()
            .0;
        (0..grid.len())
            .map(|k| if k == i { height } else { 0.5 })
            .collect()
    };
    let pi_h = std::f64::consts::PI * h;
    // At 100 Hz, and below 1 Hz, where the search's tolerance must stay relative.
    for at in [100.0, 0.5] {
        let envelope = spike(at, 4.0);
        let f0 = grid[envelope.iter().position(|&e| e > 1.0).unwrap()];
        for order in [1, 2, 4] {
            let exact = ((pi_h * f0).tan() / 3f64.powf(0.5 / order as f64)).atan() / pi_h;
            let found = max_safe_cutoff(&envelope, &grid, order, h).unwrap();
            assert!(
                found <= exact && found > exact * (1.0 - 2e-4),
                "order {order}: found {found} Hz, exact {exact} Hz"
            );
        }
    }
    assert_eq!(max_safe_cutoff(&spike(0.1, 2.5), &grid, 2, h), None);
    assert_eq!(
        max_safe_cutoff(&vec![0.9; grid.len()], &grid, 2, h),
        Some(500.0)
    );
}

/// The largest mass held for the whole of a window `dwell` long: windows of dwell / stride
/// + 1 samples, the whole series at most.
#[test]
fn the_sustained_mass_is_the_best_windows_minimum() {
    use ckcm::convergence::sustained_mass;
    let masses = [1.0, 5.0, 4.0, 6.0, 2.0];
    assert_eq!(sustained_mass(&masses, 1.0, 0.0), 6.0);
    assert_eq!(sustained_mass(&masses, 1.0, 1.0), 4.0);
    assert_eq!(sustained_mass(&masses, 0.5, 1.0), 4.0);
    assert_eq!(sustained_mass(&masses, 1.0, 10.0), 1.0);
}
