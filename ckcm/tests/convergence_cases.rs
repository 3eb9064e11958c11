//! Predictions of the convergence analysis on seven circle campaigns (docs/convergence.md):
//! the verdict from the sustained modal masses must match what 50 simulated trials show (the
//! orchestrator's `analyze_vs_simulation` test runs those campaigns through the FMUs and
//! checks the same verdicts), and the frozen worst case must stay on the safe side of it.

use ckcm::convergence::{Problem, analyse};
use ckcm::learning::{LowPass, UpdateSettings};
use ckcm::{Gains, Mechanism, Params, Trajectory};

fn circle(filter: Option<(usize, f64)>, lead: usize, gain: f64) -> Problem {
    Problem {
        plant: Mechanism::new(Params::default()).unwrap(),
        trajectory: Trajectory::circle(0.5),
        gains: Gains::default(),
        h: 1e-3,
        update: UpdateSettings {
            filter: filter.map(|(order, cutoff_hz)| LowPass { order, cutoff_hz }),
            lead,
            forgetting: 1.0,
            gain,
        },
        stride: 0.005,
        dwell: 1.0,
        search_order: 4,
    }
}

/// One circle campaign: filter (order, cutoff Hz), lead, gain and its simulated verdict.
struct Case {
    name: &'static str,
    filter: Option<(usize, f64)>,
    lead: usize,
    gain: f64,
    converges: bool,
}

const fn case(
    name: &'static str,
    filter: Option<(usize, f64)>,
    lead: usize,
    gain: f64,
    converges: bool,
) -> Case {
    Case {
        name,
        filter,
        lead,
        gain,
        converges,
    }
}

const CASES: [Case; 7] = [
    case("no filter", None, 0, 1.0, false),
    case("Q 5 Hz order 2", Some((2, 5.0)), 0, 1.0, true),
    case("Q 10 Hz order 2", Some((2, 10.0)), 0, 1.0, false),
    case("Q 8 Hz order 4 lead 25", Some((4, 8.0)), 25, 1.0, true),
    case("Q 10 Hz order 4 lead 25", Some((4, 10.0)), 25, 1.0, true),
    case("Q 10 Hz order 4 lead 30", Some((4, 10.0)), 30, 1.0, false),
    case(
        "gains x1.5, Q 8 Hz order 4 lead 25",
        Some((4, 8.0)),
        25,
        1.5,
        false,
    ),
];

#[test]
fn sustained_verdicts_match_simulation_and_worst_case_is_conservative() {
    for Case {
        name,
        filter,
        lead,
        gain,
        converges,
    } in CASES
    {
        let a = analyse(&circle(filter, lead, gain)).unwrap();
        assert_eq!(
            a.sustained.converges(),
            converges,
            "{name}: sustained peak {:?}",
            a.sustained.peak
        );
        assert!(
            a.worst_case.peak.value >= a.sustained.peak.value,
            "{name}: worst {:?} < sustained {:?}",
            a.worst_case.peak,
            a.sustained.peak
        );
    }
}

#[test]
fn circle_modes_and_unfiltered_band() {
    let a = analyse(&circle(None, 0, 1.0)).unwrap();
    // Heaviest mode: 27 kg at home, ≈ 59 kg near t = 2.7 s (docs/model.md §9: 27–57 kg).
    let heavy = &a.modes[5].spread;
    assert!(
        (heavy.min - 27.0).abs() < 0.5 && (heavy.max - 59.0).abs() < 1.0,
        "{heavy:?}"
    );
    assert!((heavy.time_of_max - 2.67).abs() < 0.1, "{heavy:?}");
    // Three light modes of ≈ 2 kg throughout.
    for m in &a.modes[..3] {
        assert!(m.spread.min > 1.5 && m.spread.max < 4.0, "{:?}", m.spread);
    }
    // Without a filter the heavy modes fail from a few Hz, the light ones near Nyquist.
    let bands = &a.unfiltered_bands;
    assert!(bands[0].0 > 3.0 && bands[0].0 < 4.0, "{bands:?}");
    assert!((bands.last().unwrap().1 - 500.0).abs() < 0.01, "{bands:?}");
    // A one-sample lead removes the high-frequency band of the light modes.
    let led = analyse(&circle(None, 1, 1.0)).unwrap();
    assert!(
        led.unfiltered_bands.iter().all(|b| b.1 < 100.0),
        "{:?}",
        led.unfiltered_bands
    );
}

#[test]
fn safe_cutoff_brackets_the_cases() {
    // Order 4, lead 25: 8 and 10 Hz converge, so the largest safe cutoff is above 10 Hz;
    // with lead 30, 10 Hz diverges, so it is below.
    let a = analyse(&circle(Some((4, 8.0)), 25, 1.0)).unwrap();
    let fc = a.sustained.max_safe_cutoff.unwrap();
    assert!(fc > 10.0 && fc < 100.0, "{fc}");
    let b = analyse(&circle(Some((4, 8.0)), 30, 1.0)).unwrap();
    let fc30 = b.sustained.max_safe_cutoff.unwrap();
    assert!(fc30 < 10.0, "{fc30}");
}

/// A stride that would sample billions of poses is refused before any is computed.
#[test]
fn a_stride_beyond_a_million_poses_is_refused() {
    let mut p = circle(None, 0, 1.0);
    p.stride = 1e-9;
    let err = analyse(&p).unwrap_err().to_string();
    assert!(err.contains("stride") && err.contains("1e5 poses"), "{err}");
    let history = ckcm::convergence::mass_history(&p.plant, &p.trajectory, 5e-3).unwrap();
    assert_eq!(history.len(), 1001, "every 5 ms along 5 s, both ends");
}

/// The unfiltered curves and bands leave the filter out and nothing else: a filtered
/// campaign's are its unfiltered twin's, and its filtered curves are those times |Q|².
#[test]
fn the_unfiltered_curves_are_the_campaign_without_its_filter() {
    let filtered = analyse(&circle(Some((2, 5.0)), 0, 1.0)).unwrap();
    let bare = analyse(&circle(None, 0, 1.0)).unwrap();
    assert_eq!(filtered.unfiltered_bands, bare.unfiltered_bands);
    assert!(!bare.unfiltered_bands.is_empty());
    for (f, b) in filtered.modes.iter().zip(&bare.modes) {
        assert_eq!(f.unfiltered, b.unfiltered);
        assert_eq!(b.worst, b.unfiltered);
        for ((w, u), q) in f.worst.iter().zip(&f.unfiltered).zip(&filtered.q_gain_sq) {
            assert!((w - u * q).abs() <= 1e-12 * u, "{w} against {u} × {q}");
        }
    }
}
