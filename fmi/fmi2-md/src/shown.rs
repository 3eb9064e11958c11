//! Reals in messages.

/// A Real as messages show it: as `{}` prints it where that is short, with an exponent
/// where `{}` would write out hundreds of zeros (`1e300`, `5e-324`), so a message stays
/// readable whatever value a caller passed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shown(pub f64);

impl std::fmt::Display for Shown {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let x = self.0;
        let magnitude = x.abs();
        if x == 0.0 || !x.is_finite() || (1e-5..1e16).contains(&magnitude) {
            write!(f, "{x}")
        } else {
            write!(f, "{x:e}")
        }
    }
}

/// The distance from |t| to the next double up: how far apart neighbouring times lie near
/// `t`, which the FMUs and the master name when a step is too small to move the time.
/// By the bits, since `f64::next_up` is newer than the workspace's MSRV.
pub fn time_spacing(t: f64) -> f64 {
    let far = t.abs();
    f64::from_bits(far.to_bits() + 1) - far
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ordinary values read as `{}` prints them; extreme ones get an exponent instead of
    /// hundreds of digits, and either text parses back to the same value.
    #[test]
    fn shown_reals_are_short_and_exact() {
        for (x, text) in [
            (0.0, "0"),
            (-0.0, "-0"),
            (0.001, "0.001"),
            (1e-5, "0.00001"),
            (15.0, "15"),
            (0.060000000000000005, "0.060000000000000005"),
            (1e7, "10000000"),
            (9.9e15, "9900000000000000"),
            (1e16, "1e16"),
            (-1e300, "-1e300"),
            (9.9e-6, "9.9e-6"),
            (5e-324, "5e-324"),
            (f64::NAN, "NaN"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            let shown = Shown(x).to_string();
            assert_eq!(shown, text, "{x:?}");
            if !x.is_nan() {
                assert_eq!(shown.parse::<f64>().map(f64::to_bits), Ok(x.to_bits()));
            }
        }
    }

    /// One unit in the last place: 2^-52 at 1, 2^-43 at 1000 (in [512, 1024)), the smallest
    /// subnormal at 0, the same on either side of zero.
    #[test]
    fn time_spacing_is_one_ulp_of_the_time() {
        assert_eq!(time_spacing(1.0), f64::EPSILON);
        assert_eq!(time_spacing(-1.0), f64::EPSILON);
        assert_eq!(time_spacing(1000.0), 2f64.powi(-43));
        assert_eq!(time_spacing(0.0), 5e-324);
    }
}
