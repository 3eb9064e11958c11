//! Per-trial figures derived from the recorded signals (docs/model.md §7): the λ-norm for
//! several ρ, the error before and after the transient, the error spectrum, the actuator
//! effort and the learned input. Written to `trial_metrics.csv`, from which the report's
//! verdicts are computed.

use std::path::Path;

use ckcm::{Trajectory, TrajectoryKind};
use rustfft::FftPlanner;
use rustfft::num_complex::Complex;

use super::cases::{Scheme, traj_slug};
use crate::output::{OutputError, Recording, write_table_csv};

/// End of the transient, s: the paper's "within 0.6 s" (Fig. 6c).
pub const TRANSIENT_END: f64 = 0.6;
/// The λ-norm weights reported, 1/s: the scenario default and a heavier one.
pub const RHOS: [f64; 2] = [1.0, 5.0];
/// Frequency above which error energy counts as high-frequency, Hz.
pub const HIGH_HZ: f64 = 5.0;

/// Derived figures of one recorded trial, SI units (m, N, Hz).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrialMetrics {
    /// Trial index (0 = no learning memory yet).
    pub trial: usize,
    /// sup_t e^(−ρt) max_leg |e(t)| for each ρ of [`RHOS`], m.
    pub lambda: [f64; 2],
    /// max |e| over legs for t < [`TRANSIENT_END`], m.
    pub transient_max: f64,
    /// Lowest signed e over legs for t ≥ [`TRANSIENT_END`], m.
    pub steady_min: f64,
    /// Highest signed e over legs for t ≥ [`TRANSIENT_END`], m.
    pub steady_max: f64,
    /// Mean signed e over legs and t ≥ [`TRANSIENT_END`], m.
    pub steady_mean: f64,
    /// max |p − p_d| for t < [`TRANSIENT_END`], m.
    pub transient_path_max: f64,
    /// Median frequency of the error energy ([`spectrum_summary`]), Hz.
    pub median_hz: f64,
    /// Share of the error energy (mean removed) above [`HIGH_HZ`].
    pub above_high: f64,
    /// RMS actuator force over legs and time, N.
    pub force_rms: f64,
    /// Peak |actuator force|, N.
    pub force_max: f64,
}

/// Column names of `trial_metrics.csv`.
pub const HEADER: [&str; 14] = [
    "trajectory",
    "scheme",
    "trial",
    "lambda_rho1",
    "lambda_rho5",
    "transient_max",
    "steady_min",
    "steady_max",
    "steady_mean",
    "transient_path_max",
    "median_hz",
    "above_5hz",
    "force_rms",
    "force_max",
];

/// The six leg-error columns of a recording, m.
pub fn leg_errors(rec: &Recording) -> Vec<&[f64]> {
    (1..=6)
        .filter_map(|leg| rec.column(&format!("controller.error[{leg}]")))
        .collect()
}

/// |p − p_d(t)| at every recorded sample, m (NaN where the pose was not recorded).
pub fn path_error(rec: &Recording, trajectory: &Trajectory) -> Vec<f64> {
    let c = |i: usize| rec.column(&format!("plant.pose[{i}]"));
    let (Some(x), Some(y), Some(z)) = (c(1), c(2), c(3)) else {
        return vec![f64::NAN; rec.time.len()];
    };
    rec.time
        .iter()
        .enumerate()
        .map(|(i, &t)| {
            let d = trajectory.sample(t).pose.p_world;
            ((x[i] - d.x).powi(2) + (y[i] - d.y).powi(2) + (z[i] - d.z).powi(2)).sqrt()
        })
        .collect()
}

/// Single-sided amplitude spectrum of the leg errors: (frequencies in Hz, amplitude in m),
/// the RMS over the legs of each leg's spectrum, each leg with its mean removed (the static
/// offset is not the oscillation of interest). Amplitude is 2|X(f)|/N (|X(f)|/N at 0 Hz and
/// Nyquist), so a sine of amplitude a centred on a bin reads a, whatever the trial's length.
/// No window: the line's high-frequency error lies in the first second of a trial, which a
/// taper would suppress. Empty for fewer than two samples.
pub fn error_spectrum(errors: &[&[f64]], step: f64) -> (Vec<f64>, Vec<f64>) {
    let n = errors.iter().map(|e| e.len()).min().unwrap_or(0);
    if n < 2 || errors.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let fft = FftPlanner::<f64>::new().plan_fft_forward(n);
    let bins = n / 2 + 1;
    let mut squares = vec![0.0; bins];
    let mut buf = vec![Complex::new(0.0, 0.0); n];
    for e in errors {
        let mean = e[..n].iter().sum::<f64>() / n as f64;
        for (b, v) in buf.iter_mut().zip(&e[..n]) {
            *b = Complex::new(v - mean, 0.0);
        }
        fft.process(&mut buf);
        for (i, (a, c)) in squares.iter_mut().zip(&buf).enumerate() {
            let one_sided = if i == 0 || 2 * i == n { 1.0 } else { 2.0 };
            *a += (one_sided * c.norm() / n as f64).powi(2);
        }
    }
    let legs = errors.len() as f64;
    let df = 1.0 / (n as f64 * step);
    (
        (0..bins).map(|i| i as f64 * df).collect(),
        squares.iter().map(|a| (a / legs).sqrt()).collect(),
    )
}

/// Frequency below which `share` of a spectrum's energy (squared amplitude, 0 Hz left out)
/// lies, Hz (NaN for an empty or zero spectrum).
pub fn energy_below(freq: &[f64], amplitude: &[f64], share: f64) -> f64 {
    let body = || freq.iter().zip(amplitude).skip(1);
    let total: f64 = body().map(|(_, a)| a * a).sum();
    let mut sum = 0.0;
    for (f, a) in body() {
        sum += a * a;
        if total > 0.0 && sum >= share * total {
            return *f;
        }
    }
    f64::NAN
}

/// Median frequency of the error energy (half of it lies above) and the share of the
/// energy above `above_hz`, from [`error_spectrum`]. The median, not the largest bin: a
/// slow transient's spectrum is largest in the lowest bins, and on the line one such bin
/// outweighs every single bin of the broad burst near 150 Hz that holds most of the energy.
pub fn spectrum_summary(freq: &[f64], amplitude: &[f64], above_hz: f64) -> (f64, f64) {
    let body = || freq.iter().zip(amplitude).skip(1);
    let total: f64 = body().map(|(_, a)| a * a).sum();
    let high: f64 = body()
        .filter(|(f, _)| **f > above_hz)
        .map(|(_, a)| a * a)
        .sum();
    (
        energy_below(freq, amplitude, 0.5),
        if total > 0.0 { high / total } else { 0.0 },
    )
}

/// Derives the metrics of one recorded trial.
pub fn trial_metrics(k: usize, rec: &Recording, trajectory: &Trajectory) -> TrialMetrics {
    let errors = leg_errors(rec);
    let mut lambda = [0.0_f64; 2];
    let mut transient_max = 0.0_f64;
    let (mut lo, mut hi, mut sum, mut count) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0usize);
    for e in &errors {
        for (&t, &v) in rec.time.iter().zip(e.iter()) {
            for (l, rho) in lambda.iter_mut().zip(RHOS) {
                *l = l.max((-rho * t).exp() * v.abs());
            }
            if t < TRANSIENT_END {
                transient_max = transient_max.max(v.abs());
            } else {
                lo = lo.min(v);
                hi = hi.max(v);
                sum += v;
                count += 1;
            }
        }
    }
    let path = path_error(rec, trajectory);
    let transient_path_max = rec
        .time
        .iter()
        .zip(&path)
        .filter(|(t, _)| **t < TRANSIENT_END)
        .fold(0.0_f64, |m, (_, p)| m.max(*p));
    let step = match rec.time.as_slice() {
        [a, b, ..] => b - a,
        _ => 1e-3,
    };
    let (freq, power) = error_spectrum(&errors, step);
    let (median_hz, above_high) = spectrum_summary(&freq, &power, HIGH_HZ);
    let forces: Vec<&[f64]> = (1..=6)
        .filter_map(|leg| rec.column(&format!("controller.force[{leg}]")))
        .collect();
    let (mut f2, mut fmax, mut fcount) = (0.0, 0.0_f64, 0usize);
    for f in &forces {
        for v in f.iter() {
            f2 += v * v;
            fmax = fmax.max(v.abs());
            fcount += 1;
        }
    }
    let nan_if_none = |n: usize, v: f64| if n > 0 { v } else { f64::NAN };
    TrialMetrics {
        trial: k,
        lambda,
        transient_max,
        steady_min: nan_if_none(count, lo),
        steady_max: nan_if_none(count, hi),
        steady_mean: nan_if_none(count, sum / count.max(1) as f64),
        transient_path_max,
        median_hz,
        above_high,
        force_rms: nan_if_none(fcount, (f2 / fcount.max(1) as f64).sqrt()),
        force_max: nan_if_none(fcount, fmax),
    }
}

/// Writes `trial_metrics.csv`: one row per recorded trial of every case.
pub fn write_trial_metrics(
    path: &Path,
    cases: &[(TrajectoryKind, Scheme, &[TrialMetrics])],
) -> Result<(), OutputError> {
    let rows: Vec<Vec<String>> = cases
        .iter()
        .flat_map(|(kind, scheme, ms)| {
            ms.iter().map(move |m| {
                [
                    traj_slug(*kind).to_string(),
                    scheme.slug().to_string(),
                    m.trial.to_string(),
                ]
                .into_iter()
                .chain(
                    [
                        m.lambda[0],
                        m.lambda[1],
                        m.transient_max,
                        m.steady_min,
                        m.steady_max,
                        m.steady_mean,
                        m.transient_path_max,
                        m.median_hz,
                        m.above_high,
                        m.force_rms,
                        m.force_max,
                    ]
                    .map(|v| v.to_string()),
                )
                .collect()
            })
        })
        .collect();
    write_table_csv(path, &HEADER, &rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spectrum_finds_a_sine_and_its_high_frequency_share() {
        let h = 1e-3;
        let t: Vec<f64> = (0..5000).map(|i| f64::from(i) * h).collect();
        let slow: Vec<f64> = t
            .iter()
            .map(|t| 0.3 + (std::f64::consts::TAU * 1.0 * t).sin())
            .collect();
        let fast: Vec<f64> = t
            .iter()
            .map(|t| 3.0 * (std::f64::consts::TAU * 6.4 * t).sin())
            .collect();
        let (f, a) = error_spectrum(&[&slow, &fast], h);
        let (median, high) = spectrum_summary(&f, &a, HIGH_HZ);
        assert!((median - 6.4).abs() < 1e-9, "{median}");
        // Energy ratio 9:1, so 90 % of the energy is above 5 Hz; the 0.3 offset is removed.
        assert!((high - 0.9).abs() < 1e-6, "{high}");
        assert_eq!(spectrum_summary(&[], &[], HIGH_HZ).1, 0.0);
        // Amplitudes in m, single-sided: the RMS over the two legs of 3 at 6.4 Hz and of 1
        // at 1 Hz (each sine on a bin centre).
        let at = |hz: f64| a[(hz / (f[1] - f[0])).round() as usize];
        assert!((at(6.4) - 3.0 / 2f64.sqrt()).abs() < 1e-9, "{}", at(6.4));
        assert!((at(1.0) - 1.0 / 2f64.sqrt()).abs() < 1e-9, "{}", at(1.0));
    }

    /// A slow bump in the first second with a short 154 Hz burst on it that holds most of
    /// the energy (the line's late trials): the median frequency lies in the burst, not in
    /// the lowest bin, where the bump's spectrum is largest.
    #[test]
    fn a_slow_transient_does_not_pass_for_the_error_frequency() {
        let h = 1e-3;
        let e: Vec<f64> = (0..15000)
            .map(|i| {
                let t = f64::from(i) * h;
                let bump = if t < 1.0 {
                    (std::f64::consts::PI * t).sin().powi(2)
                } else {
                    0.0
                };
                1e-7 * bump + 2e-6 * (-t / 0.02).exp() * (std::f64::consts::TAU * 154.0 * t).sin()
            })
            .collect();
        let (f, a) = error_spectrum(&[&e], h);
        let (median, high) = spectrum_summary(&f, &a, HIGH_HZ);
        assert!((median - 154.0).abs() < 5.0, "{median}");
        assert!(high > 0.8, "{high}");
        assert!(energy_below(&f, &a, 0.99) > median);
        assert!(energy_below(&f, &[0.0; 3], 0.5).is_nan());
    }

    #[test]
    fn metrics_split_transient_and_steady_and_weight_lambda() {
        let mut rec = Recording::new((1..=6).map(|l| format!("controller.error[{l}]")).collect());
        for i in 0..=1000 {
            let t = f64::from(i) * 1e-3;
            let e = if t < TRANSIENT_END { 2.0 } else { -0.5 };
            rec.push_row(t, &[e, 0.0, 0.0, 0.0, 0.0, 0.0]);
        }
        let m = trial_metrics(3, &rec, &Trajectory::line(0.5));
        assert_eq!(m.trial, 3);
        assert_eq!(m.transient_max, 2.0);
        assert_eq!((m.steady_min, m.steady_max), (-0.5, 0.0));
        assert!((m.steady_mean + 0.5 / 6.0).abs() < 1e-12);
        assert_eq!(m.lambda, [2.0, 2.0]);
        assert!(m.force_rms.is_nan());
    }
}
