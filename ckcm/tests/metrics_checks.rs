//! The Cartesian path error of docs/model.md §7 against distances computed by hand, with a
//! desired path away from the origin so that p − p_d and p + p_d differ.

use ckcm::metrics::path_error;

#[test]
fn path_error_is_the_distance_to_the_desired_point() {
    // Offsets (3, 4, 0) → 5, (1, 2, 2) → 3, (0, 0, −2) → 2 from desired points off the origin.
    let desired = [[0.1, -0.2, 0.8], [-0.3, 0.5, 1.1], [0.25, 0.25, 0.9]];
    let offsets = [[3.0, 4.0, 0.0], [1.0, 2.0, 2.0], [0.0, 0.0, -2.0]];
    let actual: Vec<[f64; 3]> = desired
        .iter()
        .zip(&offsets)
        .map(|(d, o)| [d[0] + o[0], d[1] + o[1], d[2] + o[2]])
        .collect();
    let p = path_error(&actual, &desired);
    assert!((p.max - 5.0).abs() < 1e-12, "max {}", p.max);
    let rms = ((25.0 + 9.0 + 4.0) / 3.0f64).sqrt();
    assert!((p.rms - rms).abs() < 1e-12, "rms {}, expected {rms}", p.rms);
    // Measured against itself the path has no error.
    let zero = path_error(&desired, &desired);
    assert_eq!((zero.max, zero.rms), (0.0, 0.0));
}
