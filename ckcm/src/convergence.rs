//! Frequency-domain convergence analysis of the learning update (docs/convergence.md,
//! docs/model.md §9).
//!
//! The mechanism is linearised along the reference: at each pose the leg-space inertia
//! M_leg = J⁻ᵀ M J⁻¹ (the plant's full model, legs included) is split into its eigenmodes.
//! Gains are scalar per leg and the viscous friction is b·I, so in the eigenbasis of M_leg
//! every mode is an independent mass m_i with friction b under the same sampled PID loop.
//! Per mode, with z = e^{jωh}, the trial-to-trial map of the memory at frequency ω is
//!
//!   u_{k+1} = Q·Q̄ [α − g z^δ L(z) P(z)] u_k + (terms that do not depend on u_k),
//!
//! so learning contracts where |Q(e^{jωh})|²·|α − g z^δ L P| < 1 (Bristow, Tharayil & Alleyne
//! 2006, eq. 23; Longman 2000). P is the sampled error sensitivity of the PID loop from the
//! learning input to the error (zero-order hold on the force, exact discretisation of the
//! mode), L the learning law Φ e + Γ ė + Ψ I of `control.rs` in its discrete form, Q the
//! Butterworth low-pass applied forward and backward (zero phase, squared magnitude).

use nalgebra::{Complex, Matrix6};

use crate::control::Gains;
use crate::dynamics::DynamicsError;
use crate::kinematics::{Mechanism, Pose};
use crate::learning::{LowPass, UpdateSettings};
use crate::trajectory::Trajectory;

/// Number of leg-space modes.
pub const MODES: usize = 6;

/// A rejected analysis setting, naming it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConvergenceError {
    #[error("{name} = {value} is invalid: {reason}")]
    Invalid {
        name: &'static str,
        value: f64,
        reason: &'static str,
    },
    #[error("at t = {time} s of the reference: {source}")]
    Dynamics {
        time: f64,
        #[source]
        source: DynamicsError,
    },
}

fn check(
    name: &'static str,
    value: f64,
    ok: bool,
    reason: &'static str,
) -> Result<(), ConvergenceError> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(ConvergenceError::Invalid {
            name,
            value,
            reason,
        })
    }
}

/// |Q(e^{jωh})|² of one pass of the low-pass `q` at frequency `f` (Hz), sample period `h`
/// (s): the forward-backward filter's whole gain. For the bilinear-transform design (scipy's
/// `butter`, prewarped at f_c, as `learning.rs`) |Q|² = 1 / (1 + (tan(πfh) / tan(πf_c h))^{2N}).
pub fn q_gain_sq(q: &LowPass, f: f64, h: f64) -> f64 {
    let r = (std::f64::consts::PI * f * h).tan() / (std::f64::consts::PI * q.cutoff_hz * h).tan();
    1.0 / (1.0 + r.abs().powi(2 * q.order as i32))
}

/// Checks `update` for sample period `h`, naming the offending setting.
pub fn validate(update: &UpdateSettings, h: f64) -> Result<(), ConvergenceError> {
    check("h", h, h > 0.0, "the sample period must be positive")?;
    check("forgetting", update.forgetting, true, "must be finite")?;
    check("gain", update.gain, true, "must be finite")?;
    if let Some(q) = update.filter {
        check(
            "order",
            q.order as f64,
            (1..=crate::learning::MAX_ORDER).contains(&q.order),
            "the filter order must be between 1 and 8 (learning::MAX_ORDER)",
        )?;
        check(
            "cutoff",
            q.cutoff_hz,
            q.cutoff_hz > 0.0 && q.cutoff_hz < 0.5 / h,
            "the cutoff must lie between 0 and the Nyquist frequency 1/(2h)",
        )?;
    }
    Ok(())
}

/// One leg-space mode under the sampled PID loop: mass m with viscous friction b, force held
/// over each sample (zero-order hold), controller of `control.rs` at period h.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeLoop {
    /// Modal mass m, kg.
    pub mass: f64,
    /// Viscous friction b, N·s/m (the plant's `viscous_friction`, default 100).
    pub viscous: f64,
    /// Feedback and learning gains.
    pub gains: Gains,
    /// Sample period h, s (default 0.001).
    pub h: f64,
}

impl ModeLoop {
    /// Exact ZOH discretisation of m ẍ + b ẋ = f over one period:
    /// x⁺ = x + c1 v + c2 f, v⁺ = p v + c3 f.
    fn zoh(&self) -> (f64, f64, f64, f64) {
        let (m, h) = (self.mass, self.h);
        let x = self.viscous / m * h; // a h with a = b / m
        let p = (-x).exp();
        // (1 − e^{−x}) / x and (x − 1 + e^{−x}) / x², by series where the differences cancel.
        let (s1, s2) = if x < 1e-4 {
            (1.0 - x / 2.0 + x * x / 6.0, 0.5 - x / 6.0 + x * x / 24.0)
        } else {
            (-(-x).exp_m1() / x, (x + (-x).exp_m1()) / (x * x))
        };
        (p, h * s1, h * h / m * s2, h / m * s1)
    }

    /// L(z)·P(z) at frequency `f` (Hz): the learning increment Δ per unit of learning input
    /// u, with the sign chosen so that the update reads α − g z^δ L P.
    ///
    /// With G_x = (c2 + c1 c3 / (z − p)) / (z − 1), G_v = c3 / (z − p) (force to position and
    /// rate at the next samples) and the running sum I_n = I_{n−1} + e_n h, i.e. h z / (z − 1):
    /// L P = [(Φ + Ψ h z/(z−1)) G_x + Γ G_v] / [1 + (Kp + Ki h z/(z−1)) G_x + Kd G_v]
    /// (paper eqs. 9, 10 and 14 on the sampled loop). Undefined at f = 0.
    pub fn learning_response(&self, f: f64) -> Complex<f64> {
        let (p, c1, c2, c3) = self.zoh();
        let g = &self.gains;
        let z = Complex::from_polar(1.0, std::f64::consts::TAU * f * self.h);
        let one = Complex::new(1.0, 0.0);
        let gv = c3 / (z - p);
        let gx = (gv * c1 + c2) / (z - one);
        let sum = z * self.h / (z - one);
        let learn = (sum * g.psi + g.phi) * gx + gv * g.gamma;
        let feedback = (sum * g.ki + g.kp) * gx + gv * g.kd + one;
        learn / feedback
    }

    /// The convergence factor |Q|²·|α − g z^δ L P| at frequency `f` (Hz).
    pub fn factor(&self, update: &UpdateSettings, f: f64) -> f64 {
        let z_lead =
            Complex::from_polar(1.0, std::f64::consts::TAU * f * self.h * update.lead as f64);
        let inner =
            Complex::new(update.forgetting, 0.0) - z_lead * self.learning_response(f) * update.gain;
        let q = update.filter.map_or(1.0, |q| q_gain_sq(&q, f, self.h));
        q * inner.norm()
    }
}

/// The spread of one leg-space mode over the path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeSpread {
    /// Lightest modal mass met, kg.
    pub min: f64,
    /// Heaviest modal mass met, kg.
    pub max: f64,
    /// Reference time of the heaviest, s.
    pub time_of_max: f64,
    /// Reference pose (x, y, z, α, β, γ) of the heaviest, m and rad.
    pub pose_of_max: [f64; 6],
}

/// Eigenvalues of the leg-space inertia at `pose`, ascending (the modal masses, kg).
pub fn modal_masses(mechanism: &Mechanism, pose: &Pose) -> Result<[f64; MODES], DynamicsError> {
    let legs = mechanism.inverse_kinematics(pose);
    let j_inv = legs
        .jacobian()
        .try_inverse()
        .ok_or(DynamicsError::SingularJacobian)?;
    let m_leg: Matrix6<f64> = j_inv.transpose() * mechanism.mass_matrix(&legs) * j_inv;
    let mut eig: [f64; MODES] = m_leg.symmetric_eigenvalues().into();
    eig.sort_by(f64::total_cmp);
    if eig[0] <= 0.0 {
        return Err(DynamicsError::SingularMass);
    }
    Ok(eig)
}

/// Most poses [`mass_history`] samples: a stride far below the trajectory's time scale
/// would otherwise run without bound. Measured with `orchestrator analyze` on the 5 s circle:
/// 1e3 poses (the default 5 ms) 0.1 s, 1e5 poses 4.4 s, 1e6 poses 475 s (the sustained-mass
/// window grows with the poses, so the cost grows faster than their number).
pub const MAX_POSES: f64 = 1e5;

/// Modal masses (ascending at each pose) along `trajectory` every `stride` seconds and at its
/// end: (time s, masses kg).
pub fn mass_history(
    mechanism: &Mechanism,
    trajectory: &Trajectory,
    stride: f64,
) -> Result<Vec<(f64, [f64; MODES])>, ConvergenceError> {
    check("stride", stride, stride > 0.0, "must be positive")?;
    check(
        "stride",
        stride,
        trajectory.duration / stride <= MAX_POSES,
        "samples more than 1e5 poses along the trajectory",
    )?;
    let n = (trajectory.duration / stride).ceil() as usize;
    (0..=n)
        .map(|i| {
            let t = (i as f64 * stride).min(trajectory.duration);
            modal_masses(mechanism, &trajectory.sample(t).pose)
                .map(|m| (t, m))
                .map_err(|source| ConvergenceError::Dynamics { time: t, source })
        })
        .collect()
}

/// Each mode's spread over a [`mass_history`] of `trajectory`.
pub fn mode_spread(
    history: &[(f64, [f64; MODES])],
    trajectory: &Trajectory,
) -> [ModeSpread; MODES] {
    let mut spread = [ModeSpread {
        min: f64::INFINITY,
        max: 0.0,
        time_of_max: 0.0,
        pose_of_max: [0.0; 6],
    }; MODES];
    for &(t, masses) in history {
        for (s, &m) in spread.iter_mut().zip(&masses) {
            s.min = s.min.min(m);
            if m > s.max {
                s.max = m;
                s.time_of_max = t;
                s.pose_of_max = trajectory.sample(t).pose.to_xyz_euler();
            }
        }
    }
    spread
}

/// Masses at which a mode is evaluated: its range in `points` even steps (the factor need
/// not be monotonic in the mass, so the ends alone are not enough).
pub fn mass_grid(spread: &ModeSpread, points: usize) -> Vec<f64> {
    let points = points.max(2);
    (0..points)
        .map(|i| spread.min + (spread.max - spread.min) * i as f64 / (points - 1) as f64)
        .collect()
}

/// Frequencies from `f_min` to just below Nyquist, logarithmically spaced, Hz.
pub fn frequency_grid(h: f64, f_min: f64, points: usize) -> Vec<f64> {
    let nyquist = 0.5 / h;
    let top = nyquist * (1.0 - 1e-6);
    let points = points.max(2);
    let ratio = (top / f_min).ln() / (points - 1) as f64;
    (0..points)
        .map(|i| f_min * (ratio * i as f64).exp())
        .collect()
}

/// The worst factor over a set of mode loops at one frequency.
pub fn worst_factor(loops: &[ModeLoop], update: &UpdateSettings, f: f64) -> f64 {
    loops
        .iter()
        .map(|l| l.factor(update, f))
        .fold(0.0, f64::max)
}

/// Frequency bands (f_lo, f_hi), Hz, on `grid` where `factor` exceeds 1, each edge refined by
/// bisection between its grid neighbours to 1e-6 relative.
pub fn bands_above_one(grid: &[f64], factor: impl Fn(f64) -> f64) -> Vec<(f64, f64)> {
    let refine = |mut lo: f64, mut hi: f64, rising: bool| {
        // Invariant: the factor is ≤ 1 at `lo` and > 1 at `hi` when rising, and the reverse
        // when falling.
        while hi - lo > 1e-6 * hi {
            let mid = 0.5 * (lo + hi);
            if (factor(mid) > 1.0) == rising {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        if rising { hi } else { lo }
    };
    let above: Vec<bool> = grid.iter().map(|&f| factor(f) > 1.0).collect();
    let mut bands = Vec::new();
    let mut start = None;
    for i in 0..grid.len() {
        match (above[i], start) {
            (true, None) => {
                start = Some(if i == 0 {
                    grid[0]
                } else {
                    refine(grid[i - 1], grid[i], true)
                });
            }
            (false, Some(s)) => {
                bands.push((s, refine(grid[i - 1], grid[i], false)));
                start = None;
            }
            _ => {}
        }
    }
    if let (Some(s), Some(&last)) = (start, grid.last()) {
        bands.push((s, last));
    }
    bands
}

/// |α − g z^δ L P| per frequency of `grid`, worst over `loops`: the factor before the filter,
/// which does not depend on the cutoff.
pub fn unfiltered_envelope(loops: &[ModeLoop], update: &UpdateSettings, grid: &[f64]) -> Vec<f64> {
    let bare = UpdateSettings {
        filter: None,
        ..*update
    };
    grid.iter()
        .map(|&f| worst_factor(loops, &bare, f))
        .collect()
}

/// The largest cutoff (Hz) of an order-`order` filter up to which every cutoff keeps
/// |Q|²·`envelope` ≤ 1 on `grid` (`envelope` from [`unfiltered_envelope`]); `None` if even
/// the lowest frequency of the grid fails as a cutoff, Nyquist if no filter is needed.
pub fn max_safe_cutoff(envelope: &[f64], grid: &[f64], order: usize, h: f64) -> Option<f64> {
    let safe = |cutoff: f64| {
        let q = LowPass {
            order,
            cutoff_hz: cutoff,
        };
        grid.iter()
            .zip(envelope)
            .all(|(&f, &e)| q_gain_sq(&q, f, h) * e <= 1.0)
    };
    let cutoffs = frequency_grid(h, grid[0], 200);
    let mut last_safe = None;
    for &fc in &cutoffs {
        if !safe(fc) {
            let (mut lo, mut hi) = (last_safe?, fc);
            while hi - lo > 1e-4 * hi {
                let mid = 0.5 * (lo + hi);
                if safe(mid) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return Some(lo);
        }
        last_safe = Some(fc);
    }
    Some(0.5 / h)
}

/// Largest mass a mode keeps for at least `dwell` seconds: max over t of the minimum over
/// [t, t + dwell] of `masses` sampled every `stride` seconds (the minimum over the whole
/// series when `dwell` exceeds it).
pub fn sustained_mass(masses: &[f64], stride: f64, dwell: f64) -> f64 {
    let w = ((dwell / stride).round() as usize).clamp(0, masses.len().saturating_sub(1));
    masses
        .windows(w + 1)
        .map(|win| win.iter().copied().fold(f64::INFINITY, f64::min))
        .fold(0.0, f64::max)
}

/// What the analysis needs: the plant along the path, the sampled loop and the update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Problem {
    /// The plant's mechanism (its full model, legs included).
    pub plant: Mechanism,
    /// The controller's reference.
    pub trajectory: Trajectory,
    /// Feedback and learning gains of the controller.
    pub gains: Gains,
    /// Sample period h, s. Default 0.001.
    pub h: f64,
    /// The between-trial update.
    pub update: UpdateSettings,
    /// Spacing of the poses sampled along the path, s. Default 0.005.
    pub stride: f64,
    /// How long a pose must last to count for the sustained-mass estimate, s. Default 1.0
    /// (docs/convergence.md: a diverging component at 4–8 Hz spans several periods plus the
    /// loop and filter transients; briefer peaks are averaged with lighter poses).
    pub dwell: f64,
    /// Filter order for the largest-safe-cutoff search when `update` has no filter. Default 4.
    pub search_order: usize,
}

/// Frequencies evaluated, and their count.
const FREQUENCIES: usize = 1500;
/// Lowest frequency evaluated, Hz (below the 27 kg loop's bandwidth by two decades).
const F_MIN: f64 = 0.05;
/// Masses per mode range.
const MASS_POINTS: usize = 7;

/// A peak of the factor: (mode index 0..6, frequency Hz, value).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    pub mode: usize,
    pub frequency: f64,
    pub value: f64,
}

/// One verdict: the peak factor over modes and frequencies, and whether it stays ≤ 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    pub peak: Peak,
    /// Largest safe cutoff (Hz) for the update's order (or `search_order`) and lead, see
    /// [`max_safe_cutoff`].
    pub max_safe_cutoff: Option<f64>,
}

impl Verdict {
    /// Learning is predicted to converge.
    pub fn converges(&self) -> bool {
        self.peak.value <= 1.0
    }
}

/// One mode's results.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeResult {
    pub spread: ModeSpread,
    /// Largest mass held for `dwell`, kg.
    pub sustained: f64,
    /// Worst factor over every mass the mode takes on the path, per frequency.
    pub worst: Vec<f64>,
    /// Worst factor over masses up to the sustained one, per frequency.
    pub sustained_factor: Vec<f64>,
    /// As `worst` without the filter (the same lead, α and g).
    pub unfiltered: Vec<f64>,
}

/// The whole analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct Analysis {
    /// Frequencies, Hz.
    pub frequencies: Vec<f64>,
    /// |Q|² per frequency (1 without a filter).
    pub q_gain_sq: Vec<f64>,
    pub modes: Vec<ModeResult>,
    /// Every mode at every pose of the path (sufficient under the frozen-pose model).
    pub worst_case: Verdict,
    /// Every mode at the masses it sustains for `dwell` (the prediction to compare with
    /// simulation).
    pub sustained: Verdict,
    /// Bands (Hz) where learning diverges without the filter, frozen worst case.
    pub unfiltered_bands: Vec<(f64, f64)>,
}

fn loops_for(p: &Problem, lo: f64, hi: f64) -> Vec<ModeLoop> {
    let s = ModeSpread {
        min: lo,
        max: hi.max(lo),
        time_of_max: 0.0,
        pose_of_max: [0.0; 6],
    };
    mass_grid(&s, MASS_POINTS)
        .into_iter()
        .map(|mass| ModeLoop {
            mass,
            viscous: p.plant.params.friction.viscous,
            gains: p.gains,
            h: p.h,
        })
        .collect()
}

fn peak_of(curves: &[&[f64]], frequencies: &[f64]) -> Peak {
    let mut best = Peak {
        mode: 0,
        frequency: frequencies[0],
        value: 0.0,
    };
    for (mode, c) in curves.iter().enumerate() {
        for (&v, &f) in c.iter().zip(frequencies) {
            if v > best.value {
                best = Peak {
                    mode,
                    frequency: f,
                    value: v,
                };
            }
        }
    }
    best
}

/// Runs the analysis.
pub fn analyse(p: &Problem) -> Result<Analysis, ConvergenceError> {
    validate(&p.update, p.h)?;
    check("dwell", p.dwell, p.dwell >= 0.0, "must not be negative")?;
    check(
        "search_order",
        p.search_order as f64,
        p.search_order >= 1,
        "the filter order must be at least 1",
    )?;
    let history = mass_history(&p.plant, &p.trajectory, p.stride)?;
    let spread = mode_spread(&history, &p.trajectory);
    let frequencies = frequency_grid(p.h, F_MIN, FREQUENCIES);
    let q_gain_sq = frequencies
        .iter()
        .map(|&f| p.update.filter.map_or(1.0, |q| q_gain_sq(&q, f, p.h)))
        .collect();
    let bare = UpdateSettings {
        filter: None,
        ..p.update
    };
    let mut modes = Vec::with_capacity(MODES);
    let mut all_worst = Vec::new();
    let mut all_sustained = Vec::new();
    for (i, s) in spread.iter().enumerate() {
        let masses: Vec<f64> = history.iter().map(|(_, m)| m[i]).collect();
        let sustained = sustained_mass(&masses, p.stride, p.dwell);
        let full = loops_for(p, s.min, s.max);
        let held = loops_for(p, s.min, sustained);
        let curve = |loops: &[ModeLoop], u: &UpdateSettings| -> Vec<f64> {
            frequencies
                .iter()
                .map(|&f| worst_factor(loops, u, f))
                .collect()
        };
        all_worst.extend_from_slice(&full);
        all_sustained.extend_from_slice(&held);
        modes.push(ModeResult {
            spread: *s,
            sustained,
            worst: curve(&full, &p.update),
            sustained_factor: curve(&held, &p.update),
            unfiltered: curve(&full, &bare),
        });
    }
    let order = p.update.filter.map_or(p.search_order, |q| q.order);
    let worst_curves: Vec<&[f64]> = modes.iter().map(|m| m.worst.as_slice()).collect();
    let held_curves: Vec<&[f64]> = modes
        .iter()
        .map(|m| m.sustained_factor.as_slice())
        .collect();
    let worst_case = Verdict {
        peak: peak_of(&worst_curves, &frequencies),
        max_safe_cutoff: max_safe_cutoff(
            &unfiltered_envelope(&all_worst, &p.update, &frequencies),
            &frequencies,
            order,
            p.h,
        ),
    };
    let sustained = Verdict {
        peak: peak_of(&held_curves, &frequencies),
        max_safe_cutoff: max_safe_cutoff(
            &unfiltered_envelope(&all_sustained, &p.update, &frequencies),
            &frequencies,
            order,
            p.h,
        ),
    };
    let unfiltered_bands = bands_above_one(&frequencies, |f| worst_factor(&all_worst, &bare, f));
    Ok(Analysis {
        frequencies,
        q_gain_sq,
        modes,
        worst_case,
        sustained,
        unfiltered_bands,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mode(mass: f64) -> ModeLoop {
        ModeLoop {
            mass,
            viscous: 100.0,
            gains: Gains::default(),
            h: 1e-3,
        }
    }

    /// The peak of a factor curve on a fine linear grid: (frequency, value).
    fn peak(l: &ModeLoop, u: &UpdateSettings, lo: f64, hi: f64) -> (f64, f64) {
        (0..=20000)
            .map(|i| lo + (hi - lo) * i as f64 / 20000.0)
            .map(|f| (f, l.factor(u, f)))
            .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a })
    }

    #[test]
    fn zoh_matches_the_continuous_step_response() {
        // m ẍ + b ẋ = f from rest over one period, closed form.
        let l = mode(27.0);
        let (p, c1, c2, c3) = l.zoh();
        let a: f64 = 100.0 / 27.0;
        let h: f64 = 1e-3;
        let v = (1.0 - (-a * h).exp()) / 100.0;
        let x = (h - (1.0 - (-a * h).exp()) / a) / 100.0;
        assert!(
            (c3 - v).abs() < 1e-15 && (c2 - x).abs() < 1e-15,
            "{c2} {c3}"
        );
        assert!((p - (-a * h).exp()).abs() < 1e-15);
        assert!((c1 - (1.0 - p) / a).abs() < 1e-15);
        // Frictionless limit: the series branch.
        let free = ModeLoop { viscous: 0.0, ..l };
        let (p, c1, c2, c3) = free.zoh();
        assert_eq!(p, 1.0);
        assert!((c1 - h).abs() < 1e-18);
        assert!((c2 - h * h / 2.0 / 27.0).abs() < 1e-18);
        assert!((c3 - h / 27.0).abs() < 1e-18);
    }

    /// Both sides of the switch from the closed form to the series (x = b h / m = 1e-4)
    /// against the series summed to eight terms, which is exact there: the code's three
    /// terms within their truncation (x³ / 24 < 5e-14), the closed form within the
    /// cancellation it suffers (about 2ε / x).
    #[test]
    fn zoh_series_and_closed_form_agree_where_they_meet() {
        let h: f64 = 1e-3;
        for x in [0.5e-4, 0.99e-4, 1.01e-4, 2e-4] {
            let mass = 100.0 * h / x;
            let (p, c1, c2, c3) = mode(mass).zoh();
            let x = 100.0 / mass * h;
            // s1 = Σ (−x)^k / (k + 1)!, s2 = Σ (−x)^k / (k + 2)!.
            let (mut s1, mut s2, mut term) = (0.0, 0.0, 1.0);
            for k in 0..8 {
                s1 += term / (k + 1) as f64;
                s2 += term / ((k + 1) * (k + 2)) as f64;
                term *= -x / (k + 1) as f64;
            }
            let tol = if x < 1e-4 { 1e-13 } else { 1e-10 };
            let close = |got: f64, want: f64| (got / want - 1.0).abs() < tol;
            assert!(close(p, (-x).exp()), "x = {x}: p = {p}");
            assert!(close(c1, h * s1), "x = {x}: c1 = {c1}, series {}", h * s1);
            assert!(close(c2, h * h / mass * s2), "x = {x}: c2 = {c2}");
            assert!(close(c3, h / mass * s1), "x = {x}: c3 = {c3}");
        }
    }

    #[test]
    fn low_frequency_factor_is_one_minus_psi_over_ki() {
        // The integral feedback drives the position error to zero for a constant u; what
        // remains of Δ is Ψ I with Ki I = −u, so L P → Ψ / Ki well below the integral
        // corner Ki / (2π Kp) ≈ 3e-5 Hz; above it, P-dominated, L P ≈ Φ / Kp.
        let l = mode(27.0);
        let lp = l.learning_response(1e-8);
        assert!((lp.re - 0.75).abs() < 1e-3 && lp.im.abs() < 1e-3, "{lp}");
        let lp = l.learning_response(0.01);
        assert!((lp.re - 47728.0 / 50000.0).abs() < 1e-3, "{lp}");
    }

    #[test]
    fn prototype_single_mode_figures() {
        let paper = UpdateSettings::default();
        for (mass, onset, f_peak, value) in [(27.0, 6.1, 8.5, 1.35), (57.0, 3.7, 5.2, 1.84)] {
            let l = mode(mass);
            let bands = bands_above_one(&frequency_grid(1e-3, 0.1, 2000), |f| l.factor(&paper, f));
            let (fp, v) = peak(&l, &paper, 0.5, 30.0);
            assert!((bands[0].0 - onset).abs() < 0.1, "{mass} kg: {bands:?}");
            assert!(
                (fp - f_peak).abs() < 0.1 && (v - value).abs() < 0.01,
                "{mass} kg: {fp} {v}"
            );
        }
    }

    /// docs/convergence.md §1: light modes exceed 1 from 125 / 104 / 90 Hz to Nyquist
    /// without a lead, and nowhere with a lead of one sample.
    #[test]
    fn light_modes_diverge_at_high_frequency_unless_led() {
        let paper = UpdateSettings::default();
        let led = UpdateSettings {
            lead: 1,
            ..UpdateSettings::default()
        };
        for (mass, onset) in [(1.5, 125.0), (2.0, 104.0), (2.5, 90.0)] {
            let l = mode(mass);
            let grid = frequency_grid(1e-3, 0.1, 2000);
            let bands = bands_above_one(&grid, |f| l.factor(&paper, f));
            assert_eq!(bands.len(), 1, "{mass} kg: {bands:?}");
            assert!((bands[0].0 - onset).abs() < 1.0, "{mass} kg: {bands:?}");
            assert!(bands[0].1 > 499.0, "{mass} kg: up to Nyquist: {bands:?}");
            let with_lead = bands_above_one(&grid, |f| l.factor(&led, f));
            assert!(with_lead.is_empty(), "{mass} kg with δ = 1: {with_lead:?}");
        }
    }
}
