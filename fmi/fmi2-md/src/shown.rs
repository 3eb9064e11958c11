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
