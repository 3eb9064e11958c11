//! The between-trial memory update of robust learning (docs/model.md §9):
//!
//! u_{k+1} = Q[ α·u_k + g·shift_δ(m_k − u_k) ]
//!
//! with u_k the memory read in trial k, m_k the `memory_next` written in trial k,
//! shift_δ(Δ)(n) = Δ(n+δ) for n + δ < N and Δ(N−1) for the last δ samples (a phase lead:
//! learn from e_k(t + δh)), and Q a Butterworth low-pass applied forward and backward over
//! the whole trial with Gustafsson's initial conditions (zero phase, no edge transients).
//!
//! Q is defined as scipy's `filtfilt(b, a, x, axis=0, method="gust")` with
//! `b, a = butter(order, cutoff, fs=1/h)`, so another FMI master can apply the same update
//! with scipy. The filter is hand-written rather than taken from a crate because the
//! numerator/denominator form of a 4th-order 8 Hz low-pass at 1 kHz is ill-conditioned
//! (Σa ≈ 6·10⁻⁶ from coefficients of order 1): agreeing with scipy to 1e-9 needs the same
//! design arithmetic (scipy's zpk → ba path, numpy's complex division) and the same
//! direct-form-II-transposed recursion, which no Rust filter crate promises.

use nalgebra::DMatrix;

/// Highest filter order accepted: the numerator/denominator form loses about one digit per
/// order at low normalised cutoffs, and orders above 8 are never needed for a Q-filter.
pub const MAX_ORDER: usize = 8;

/// A setting the update cannot use.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UpdateError {
    #[error("filter order {0} must be between 1 and {MAX_ORDER}")]
    Order(usize),
    #[error(
        "cutoff {cutoff} Hz must lie strictly between 0 and the Nyquist frequency {nyquist} Hz"
    )]
    Cutoff { cutoff: f64, nyquist: f64 },
    #[error("sample rate {0} Hz must be positive and finite")]
    SampleRate(f64),
    #[error("a zero-phase filter of order {order} needs more than {min} samples, a trial has {samples}", min = 2 * order)]
    TooShort { order: usize, samples: usize },
    #[error("lead {lead} samples must be less than the {samples} samples of a trial")]
    Lead { lead: usize, samples: usize },
    #[error("{name} = {value} must be a finite number")]
    NotFinite { name: &'static str, value: f64 },
}

/// A digital filter b(z)/a(z) with a\[0\] = 1, coefficients in powers of z⁻¹.
#[derive(Debug, Clone, PartialEq)]
pub struct TransferFunction {
    pub b: Vec<f64>,
    pub a: Vec<f64>,
}

impl TransferFunction {
    /// Filter order (number of state variables).
    pub fn order(&self) -> usize {
        self.a.len() - 1
    }
}

/// A complex number with numpy's arithmetic. Division follows numpy's Smith-type algorithm
/// (num-complex divides naively), so the designed coefficients match scipy's to the bit
/// as far as the shared libm allows.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Cx {
    re: f64,
    im: f64,
}

impl Cx {
    fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }

    fn add(self, o: Cx) -> Cx {
        Cx::new(self.re + o.re, self.im + o.im)
    }

    fn sub(self, o: Cx) -> Cx {
        Cx::new(self.re - o.re, self.im - o.im)
    }

    fn mul(self, o: Cx) -> Cx {
        Cx::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }

    fn div(self, o: Cx) -> Cx {
        let (a, b, c, d) = (self.re, self.im, o.re, o.im);
        if c.abs() >= d.abs() {
            let rat = d / c;
            let scl = 1.0 / (c + d * rat);
            Cx::new((a + b * rat) * scl, (b - a * rat) * scl)
        } else {
            let rat = c / d;
            let scl = 1.0 / (d + c * rat);
            Cx::new((a * rat + b) * scl, (b * rat - a) * scl)
        }
    }
}

/// Butterworth low-pass of `order` with −3 dB `cutoff_hz` for samples at `sample_rate_hz`:
/// the analog prototype, prewarped and mapped by the bilinear transform, as scipy's
/// `butter(order, cutoff_hz, fs=sample_rate_hz)` (output "ba").
pub fn butter_lowpass(
    order: usize,
    cutoff_hz: f64,
    sample_rate_hz: f64,
) -> Result<TransferFunction, UpdateError> {
    if !(1..=MAX_ORDER).contains(&order) {
        return Err(UpdateError::Order(order));
    }
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(UpdateError::SampleRate(sample_rate_hz));
    }
    let nyquist = sample_rate_hz / 2.0;
    // Normalised to Nyquist, as scipy does before designing.
    let wn = 2.0 * cutoff_hz / sample_rate_hz;
    if !(wn.is_finite() && wn > 0.0 && wn < 1.0) {
        return Err(UpdateError::Cutoff {
            cutoff: cutoff_hz,
            nyquist,
        });
    }
    // Analog prototype poles −exp(jπm/(2N)), m = −N+1, −N+3, …, N−1 (scipy `buttap`).
    // numpy divides the complex jπm by the real 2N as a complex division: π·m·(1/(2N)).
    let inv_2n = 1.0 / (2 * order) as f64;
    let poles_s: Vec<Cx> = (0..order)
        .map(|i| {
            let m = -(order as f64) + 1.0 + 2.0 * i as f64;
            let theta = (std::f64::consts::PI * m) * inv_2n;
            Cx::new(-theta.cos(), -theta.sin())
        })
        .collect();
    // Prewarp for the bilinear transform at fs = 2 (normalised frequencies).
    let fs = 2.0;
    let warped = 2.0 * fs * (std::f64::consts::PI * wn / fs).tan();
    let poles_s: Vec<Cx> = poles_s
        .iter()
        .map(|p| Cx::new(warped * p.re, warped * p.im))
        .collect();
    // Python's `wo**degree` is libm pow.
    let k_s = warped.powf(order as f64);
    // Bilinear transform: z = (2fs + s)/(2fs − s); the N zeros at infinity go to z = −1.
    let fs2 = Cx::new(2.0 * fs, 0.0);
    let poles_z: Vec<Cx> = poles_s
        .iter()
        .map(|&p| fs2.add(p).div(fs2.sub(p)))
        .collect();
    let mut prod = fs2.sub(poles_s[0]);
    for &p in &poles_s[1..] {
        prod = prod.mul(fs2.sub(p));
    }
    let k_z = k_s * Cx::new(1.0, 0.0).div(prod).re;
    // b = k·(z + 1)^N: binomial coefficients, exact in f64 for N ≤ MAX_ORDER.
    let mut binomial = vec![1.0; order + 1];
    for i in 1..order {
        binomial[i] = binomial[i - 1] * (order + 1 - i) as f64 / i as f64;
    }
    let b = binomial.iter().map(|c| k_z * c).collect();
    // a = ∏(1 − p z⁻¹), expanded one root at a time in complex arithmetic as numpy's
    // `poly` does; the conjugate pairs make the imaginary parts vanish.
    let mut a = vec![Cx::new(1.0, 0.0)];
    for &p in &poles_z {
        let minus_p = Cx::new(-p.re, -p.im);
        let mut next = Vec::with_capacity(a.len() + 1);
        next.push(a[0]);
        for i in 1..a.len() {
            next.push(a[i].add(a[i - 1].mul(minus_p)));
        }
        next.push(a[a.len() - 1].mul(minus_p));
        a = next;
    }
    Ok(TransferFunction {
        b,
        a: a.iter().map(|c| c.re).collect(),
    })
}

/// One step of the direct-form-II-transposed recursion (scipy `lfilter`), state `z`.
#[inline]
fn lfilter_step(tf: &TransferFunction, z: &mut [f64], x: f64) -> f64 {
    let (b, a) = (&tf.b, &tf.a);
    let order = z.len();
    let y = z[0] + b[0] * x;
    for i in 0..order - 1 {
        z[i] = z[i + 1] + x * b[i + 1] - y * a[i + 1];
    }
    z[order - 1] = x * b[order] - y * a[order];
    y
}

/// `y = lfilter(b, a, x)` from rest, forwards (`reverse` false) or over the reversed
/// sequence with the result reversed back (`lfilter(b, a, x[::-1])[::-1]`).
fn lfilter(tf: &TransferFunction, z: &mut [f64], x: &[f64], y: &mut [f64], reverse: bool) {
    z.fill(0.0);
    if reverse {
        for i in (0..x.len()).rev() {
            y[i] = lfilter_step(tf, z, x[i]);
        }
    } else {
        for i in 0..x.len() {
            y[i] = lfilter_step(tf, z, x[i]);
        }
    }
}

/// Zero-phase forward-backward filtering of signals of a fixed length with Gustafsson's
/// initial conditions (F. Gustafsson, "Determining the initial states in forward-backward
/// filtering", IEEE Trans. Signal Processing 44(4), 1996): the forward-backward and
/// backward-forward results are made to agree in the least-squares sense, eqs. (5)–(7).
///
/// Everything that depends only on the filter and the length (the observability matrix O,
/// S, and the pseudo-inverse of M = [Sᴿ − O, Oᴿ − S]) is computed once; [`ZeroPhase::apply`]
/// then allocates nothing.
#[derive(Debug, Clone)]
pub struct ZeroPhase {
    tf: TransferFunction,
    samples: usize,
    /// O, column-major `[column * samples + row]`: output of the free filter from unit state k.
    obs: Vec<f64>,
    /// S: O reversed and filtered from rest, column-major.
    s: Vec<f64>,
    /// Pseudo-inverse of M, row-major `2·order × samples`.
    pinv: Vec<f64>,
    y_f: Vec<f64>,
    y_fb: Vec<f64>,
    y_b: Vec<f64>,
    y_bf: Vec<f64>,
    z: Vec<f64>,
    ic: Vec<f64>,
}

impl ZeroPhase {
    /// Prepares filtering of `samples`-long signals by `tf`.
    pub fn new(tf: TransferFunction, samples: usize) -> Result<Self, UpdateError> {
        let order = tf.order();
        if order == 0 || order > MAX_ORDER {
            return Err(UpdateError::Order(order));
        }
        if samples <= 2 * order {
            return Err(UpdateError::TooShort { order, samples });
        }
        let n = samples;
        let mut z = vec![0.0; order];
        // Column 0 of O: the zero-input response from state e₀; column k is it delayed by k.
        let mut obs = vec![0.0; n * order];
        z[0] = 1.0;
        for o in obs.iter_mut().take(n) {
            *o = lfilter_step(&tf, &mut z, 0.0);
        }
        for k in 1..order {
            for i in k..n {
                obs[k * n + i] = obs[i - k];
            }
        }
        // S = lfilter(b, a, O reversed), column by column.
        let mut s = vec![0.0; n * order];
        let mut reversed = vec![0.0; n];
        for k in 0..order {
            for i in 0..n {
                reversed[i] = obs[k * n + n - 1 - i];
            }
            lfilter(&tf, &mut z, &reversed, &mut s[k * n..(k + 1) * n], false);
        }
        let m = DMatrix::from_fn(n, 2 * order, |i, j| {
            if j < order {
                s[j * n + n - 1 - i] - obs[j * n + i]
            } else {
                let k = j - order;
                obs[k * n + n - 1 - i] - s[k * n + i]
            }
        });
        // Least squares as LAPACK gelsd (scipy `lstsq`): singular values below ε·σ_max
        // count as zero.
        let svd = m.svd(true, true);
        let sigma_max = svd.singular_values.max();
        let pinv_m = svd
            .pseudo_inverse(f64::EPSILON * sigma_max)
            .map_err(|_| UpdateError::TooShort { order, samples })?;
        let pinv = (0..2 * order)
            .flat_map(|r| (0..n).map(move |c| (r, c)))
            .map(|(r, c)| pinv_m[(r, c)])
            .collect();
        Ok(Self {
            tf,
            samples,
            obs,
            s,
            pinv,
            y_f: vec![0.0; n],
            y_fb: vec![0.0; n],
            y_b: vec![0.0; n],
            y_bf: vec![0.0; n],
            z,
            ic: vec![0.0; 2 * order],
        })
    }

    /// Filters `x` in place (`x.len()` must be the length the filter was prepared for).
    pub fn apply(&mut self, x: &mut [f64]) {
        assert_eq!(x.len(), self.samples, "signal length");
        let n = self.samples;
        let order = self.tf.order();
        // Naive forward-backward and backward-forward passes from rest.
        lfilter(&self.tf, &mut self.z, x, &mut self.y_f, false);
        lfilter(&self.tf, &mut self.z, &self.y_f, &mut self.y_fb, true);
        lfilter(&self.tf, &mut self.z, x, &mut self.y_b, true);
        lfilter(&self.tf, &mut self.z, &self.y_b, &mut self.y_bf, false);
        // Optimal initial states: least-squares solution of M·ic = y_bf − y_fb.
        for (j, ic) in self.ic.iter_mut().enumerate() {
            let row = &self.pinv[j * n..(j + 1) * n];
            *ic = row
                .iter()
                .zip(self.y_bf.iter().zip(&self.y_fb))
                .map(|(p, (bf, fb))| p * (bf - fb))
                .sum();
        }
        // Eq. (7): y = y_fb + [Sᴿ, Oᴿ]·ic.
        for (i, out) in x.iter_mut().enumerate() {
            let r = n - 1 - i;
            let mut w = 0.0;
            for k in 0..order {
                w += self.s[k * n + r] * self.ic[k];
            }
            for k in 0..order {
                w += self.obs[k * n + r] * self.ic[order + k];
            }
            *out = self.y_fb[i] + w;
        }
    }
}

/// The Q-filter of the update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LowPass {
    /// Butterworth order N_Q, ≥ 1.
    pub order: usize,
    /// −3 dB cutoff f_c, Hz, below the Nyquist frequency 1/(2h).
    pub cutoff_hz: f64,
}

/// Settings of the update of one memory channel. The default is the paper's update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateSettings {
    /// Zero-phase low-pass Q; `None`: no filter.
    pub filter: Option<LowPass>,
    /// Phase lead δ, samples (default 0), less than the samples of a trial.
    pub lead: usize,
    /// Forgetting factor α (default 1).
    pub forgetting: f64,
    /// Gain g on the learning increment (default 1).
    pub gain: f64,
}

impl Default for UpdateSettings {
    fn default() -> Self {
        Self {
            filter: None,
            lead: 0,
            forgetting: 1.0,
            gain: 1.0,
        }
    }
}

impl UpdateSettings {
    /// Whether this is the paper's update, m_k becoming u_{k+1} unchanged.
    pub fn is_identity(&self) -> bool {
        self.filter.is_none() && self.lead == 0 && self.forgetting == 1.0 && self.gain == 1.0
    }
}

/// The update of one memory channel of `width` interleaved signals
/// (`[sample * width + element]`), prepared for trials of a fixed length.
#[derive(Debug, Clone)]
pub struct MemoryUpdate {
    settings: UpdateSettings,
    width: usize,
    q: Option<ZeroPhase>,
    column: Vec<f64>,
}

impl MemoryUpdate {
    /// Validates `settings` for trials of `samples` samples at `step_size` s and prepares
    /// the filter.
    pub fn new(
        settings: UpdateSettings,
        samples: usize,
        width: usize,
        step_size: f64,
    ) -> Result<Self, UpdateError> {
        for (name, value) in [("forgetting", settings.forgetting), ("gain", settings.gain)] {
            if !value.is_finite() {
                return Err(UpdateError::NotFinite { name, value });
            }
        }
        if settings.lead >= samples {
            return Err(UpdateError::Lead {
                lead: settings.lead,
                samples,
            });
        }
        let q = match settings.filter {
            None => None,
            Some(f) => {
                let tf = butter_lowpass(f.order, f.cutoff_hz, 1.0 / step_size)?;
                Some(ZeroPhase::new(tf, samples)?)
            }
        };
        Ok(Self {
            settings,
            width,
            q,
            column: vec![0.0; samples],
        })
    }

    /// The settings applied.
    pub fn settings(&self) -> &UpdateSettings {
        &self.settings
    }

    /// Turns `next` (m_k, written during trial k) into u_{k+1}, given `read` (u_k).
    /// Allocates nothing; with the paper's settings it leaves `next` untouched.
    pub fn apply(&mut self, read: &[f64], next: &mut [f64]) {
        if self.settings.is_identity() {
            return;
        }
        let (w, n) = (self.width, self.column.len());
        assert_eq!(read.len(), n * w, "memory length");
        assert_eq!(next.len(), n * w, "memory length");
        let UpdateSettings {
            lead,
            forgetting: alpha,
            gain: g,
            ..
        } = self.settings;
        for e in 0..w {
            for (i, x) in self.column.iter_mut().enumerate() {
                let j = (i + lead).min(n - 1);
                let delta = next[j * w + e] - read[j * w + e];
                *x = alpha * read[i * w + e] + g * delta;
            }
            if let Some(q) = &mut self.q {
                q.apply(&mut self.column);
            }
            for (i, x) in self.column.iter().enumerate() {
                next[i * w + e] = *x;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn butterworth_has_unit_dc_gain_and_half_power_at_the_cutoff() {
        for (order, fc) in [(1, 50.0), (2, 5.0), (4, 8.0), (6, 120.0)] {
            let tf = butter_lowpass(order, fc, 1000.0).unwrap();
            let gain = |f: f64| {
                let w = 2.0 * std::f64::consts::PI * f / 1000.0;
                let eval = |c: &[f64]| {
                    c.iter()
                        .enumerate()
                        .fold(Cx::new(0.0, 0.0), |acc, (k, &ck)| {
                            let kw = -(k as f64) * w;
                            acc.add(Cx::new(ck * kw.cos(), ck * kw.sin()))
                        })
                };
                let (nb, da) = (eval(&tf.b), eval(&tf.a));
                (nb.re.hypot(nb.im)) / (da.re.hypot(da.im))
            };
            assert!(
                (gain(0.0) - 1.0).abs() < 1e-8,
                "order {order}: DC {}",
                gain(0.0)
            );
            let half = gain(fc);
            assert!(
                (half - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-8,
                "order {order}: |H(fc)| = {half}"
            );
            assert!(gain(2.0 * fc) < half);
        }
    }

    /// Both branches of the scaled division (|re| ≥ |im| of the divisor and the other way
    /// round) against the textbook quotient ((ac + bd) + (bc − ad)i) / (c² + d²), which is
    /// exact to a few ulps at these magnitudes.
    #[test]
    fn complex_division_matches_the_textbook_quotient() {
        let cases = [
            (Cx::new(1.5, -2.0), Cx::new(3.0, 0.5)),
            (Cx::new(1.5, -2.0), Cx::new(0.5, 3.0)),
            (Cx::new(-0.25, 4.0), Cx::new(-0.7, -2.9)),
            (Cx::new(-0.25, 4.0), Cx::new(2.9, -0.7)),
            (Cx::new(1.0, 0.0), Cx::new(0.0, -2.0)),
        ];
        for (x, y) in cases {
            let q = x.div(y);
            let n = y.re * y.re + y.im * y.im;
            let re = (x.re * y.re + x.im * y.im) / n;
            let im = (x.im * y.re - x.re * y.im) / n;
            assert!(
                (q.re - re).abs() <= 1e-15 * re.abs().max(1.0)
                    && (q.im - im).abs() <= 1e-15 * im.abs().max(1.0),
                "{x:?} / {y:?} = {q:?}, textbook ({re}, {im})"
            );
        }
    }

    #[test]
    fn bad_settings_are_refused() {
        assert_eq!(butter_lowpass(0, 8.0, 1000.0), Err(UpdateError::Order(0)));
        assert!(matches!(
            butter_lowpass(4, 500.0, 1000.0),
            Err(UpdateError::Cutoff { .. })
        ));
        assert!(matches!(
            butter_lowpass(4, f64::NAN, 1000.0),
            Err(UpdateError::Cutoff { .. })
        ));
        assert_eq!(
            butter_lowpass(2, 600.0, 1000.0),
            Err(UpdateError::Cutoff {
                cutoff: 600.0,
                nyquist: 500.0
            })
        );
        assert_eq!(
            butter_lowpass(2, 0.0, 1000.0),
            Err(UpdateError::Cutoff {
                cutoff: 0.0,
                nyquist: 500.0
            })
        );
        for rate in [0.0, -1000.0, f64::INFINITY, f64::NAN] {
            assert!(
                matches!(
                    butter_lowpass(2, 10.0, rate),
                    Err(UpdateError::SampleRate(_))
                ),
                "sample rate {rate}"
            );
        }
        let s = UpdateSettings {
            lead: 10,
            ..Default::default()
        };
        assert!(matches!(
            MemoryUpdate::new(s, 10, 1, 1e-3),
            Err(UpdateError::Lead { .. })
        ));
        let s = UpdateSettings {
            gain: f64::NAN,
            ..Default::default()
        };
        assert!(matches!(
            MemoryUpdate::new(s, 10, 1, 1e-3),
            Err(UpdateError::NotFinite { name: "gain", .. })
        ));
    }

    #[test]
    fn zero_phase_filter_keeps_constants_and_low_frequencies_in_phase() {
        let tf = butter_lowpass(4, 8.0, 1000.0).unwrap();
        let mut q = ZeroPhase::new(tf, 2000).unwrap();
        // A constant passes, even at the edges (Gustafsson's initial states). Not to the
        // bit: the rounded coefficients of the numerator/denominator form put the edges
        // 4e-8 relative off, in scipy as well.
        let mut x = vec![0.25; 2000];
        q.apply(&mut x);
        for v in &x {
            assert!((v - 0.25).abs() < 1e-7 * 0.25, "{v}");
        }
        // A 1 Hz sine keeps its phase: zero crossings stay put.
        let sine = |i: usize| (2.0 * std::f64::consts::PI * i as f64 / 1000.0).sin();
        let mut x: Vec<f64> = (0..2000).map(sine).collect();
        q.apply(&mut x);
        for (i, v) in x.iter().enumerate().take(1800).skip(200) {
            assert!((v - sine(i)).abs() < 2e-3, "sample {i}: {v} vs {}", sine(i));
        }
    }

    #[test]
    fn paper_settings_leave_the_memory_untouched_and_the_lead_shifts() {
        let read = vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let next0 = vec![1.5, 2.5, 3.5, 4.5, 6.0, 7.0];
        let mut next = next0.clone();
        MemoryUpdate::new(UpdateSettings::default(), 3, 2, 1e-3)
            .unwrap()
            .apply(&read, &mut next);
        assert_eq!(next, next0);
        // Lead 1: sample n learns from the increment at n + 1; the last repeats.
        let s = UpdateSettings {
            lead: 1,
            ..Default::default()
        };
        let mut next = next0.clone();
        MemoryUpdate::new(s, 3, 2, 1e-3)
            .unwrap()
            .apply(&read, &mut next);
        assert_eq!(next, vec![1.5, 2.5, 4.0, 5.0, 6.0, 7.0]);
        // Forgetting and gain.
        let s = UpdateSettings {
            forgetting: 0.5,
            gain: 2.0,
            ..Default::default()
        };
        let mut next = next0.clone();
        MemoryUpdate::new(s, 3, 2, 1e-3)
            .unwrap()
            .apply(&read, &mut next);
        assert_eq!(next, vec![1.5, 2.0, 2.5, 3.0, 4.5, 5.0]);
        // Each alone is not the paper's update either.
        for (forgetting, gain, expected) in [
            (0.5, 1.0, [1.0, 1.5, 2.0, 2.5, 3.5, 4.0]),
            (1.0, 2.0, [2.0, 3.0, 4.0, 5.0, 7.0, 8.0]),
        ] {
            let s = UpdateSettings {
                forgetting,
                gain,
                ..Default::default()
            };
            let mut update = MemoryUpdate::new(s, 3, 2, 1e-3).unwrap();
            assert_eq!(update.settings(), &s);
            let mut next = next0.clone();
            update.apply(&read, &mut next);
            assert_eq!(next, expected, "forgetting {forgetting}, gain {gain}");
        }
        // The paper's update hands m_k on bit for bit, where u_k + (m_k − u_k) would not
        // (1.1 + (0.1 − 1.1) = 0.10000000000000009).
        let read = vec![1.1, 2.3, 3.3];
        let next0 = vec![0.1, 0.2, 0.35];
        let mut next = next0.clone();
        MemoryUpdate::new(UpdateSettings::default(), 3, 1, 1e-3)
            .unwrap()
            .apply(&read, &mut next);
        assert_eq!(next, next0);
    }
}
