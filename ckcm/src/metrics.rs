//! Error metrics of one trial (docs/model.md §7): max, RMS and λ-norm per leg and overall,
//! and the Cartesian path error.

/// Max |e|, RMS e and λ-norm sup_t e^(−ρt)|e(t)| of one signal (or of all legs together).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ErrorStats {
    pub max: f64,
    pub rms: f64,
    pub lambda: f64,
}

/// Per-leg and overall statistics of a leg-error history.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LegErrorMetrics {
    pub per_leg: [ErrorStats; 6],
    /// Max and λ-norm over all legs and samples; RMS over all legs and samples.
    pub overall: ErrorStats,
}

/// Statistics of the leg errors `errors[sample][leg]` sampled at `time`, with weight ρ (1/s)
/// for the λ-norm. The λ-norm uses the infinity norm across legs at each sample. The errors
/// come a sample at a time, as a master produces them: one store per step where six
/// per-leg columns took six (BENCHMARKS.md, round 33).
pub fn leg_error_metrics(time: &[f64], errors: &[[f64; 6]], rho: f64) -> LegErrorMetrics {
    let mut out = LegErrorMetrics::default();
    let n = time.len();
    if n == 0 {
        return out;
    }
    // The weights e^(−ρt) once for all six legs: the exponential was 1 % of a whole trial.
    let weights: Vec<f64> = time.iter().map(|&t| (-rho * t).exp()).collect();
    let mut total_sq = 0.0;
    for leg in 0..6 {
        let mut sq = 0.0;
        let stats = &mut out.per_leg[leg];
        for (x, &w) in errors.iter().map(|row| row[leg]).zip(&weights) {
            let a = x.abs();
            stats.max = stats.max.max(a);
            stats.lambda = stats.lambda.max(w * a);
            sq += x * x;
        }
        stats.rms = (sq / n as f64).sqrt();
        total_sq += sq;
        out.overall.max = out.overall.max.max(stats.max);
        out.overall.lambda = out.overall.lambda.max(stats.lambda);
    }
    out.overall.rms = (total_sq / (6 * n) as f64).sqrt();
    out
}

/// Maximum and RMS of the Cartesian path error |p − p_d|, m.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PathErrorStats {
    pub max: f64,
    pub rms: f64,
}

/// Path error between actual and desired positions, sample by sample.
pub fn path_error(actual: &[[f64; 3]], desired: &[[f64; 3]]) -> PathErrorStats {
    let n = actual.len().min(desired.len());
    if n == 0 {
        return PathErrorStats::default();
    }
    let mut max: f64 = 0.0;
    let mut sq = 0.0;
    for (a, d) in actual.iter().zip(desired) {
        let e2 = (a[0] - d[0]).powi(2) + (a[1] - d[1]).powi(2) + (a[2] - d[2]).powi(2);
        max = max.max(e2.sqrt());
        sq += e2;
    }
    PathErrorStats {
        max,
        rms: (sq / n as f64).sqrt(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_of_known_signals() {
        let time = [0.0, 1.0, 2.0, 3.0];
        let e1 = [1.0, -2.0, 0.5, 0.0];
        let e2 = [0.0, 0.0, 0.0, 4.0];
        let rows: Vec<[f64; 6]> = (0..4).map(|k| [e1[k], e2[k], 0.0, 0.0, 0.0, 0.0]).collect();
        let m = leg_error_metrics(&time, &rows, 1.0);
        assert_eq!(m.per_leg[0].max, 2.0);
        assert!((m.per_leg[0].rms - (5.25f64 / 4.0).sqrt()).abs() < 1e-15);
        assert!((m.per_leg[0].lambda - 1.0).abs() < 1e-15); // e^0·1 beats e^-1·2
        assert!((m.per_leg[1].lambda - 4.0 * (-3.0f64).exp()).abs() < 1e-15);
        assert_eq!(m.overall.max, 4.0);
        assert!((m.overall.rms - (21.25f64 / 24.0).sqrt()).abs() < 1e-15);
        assert_eq!(m.overall.lambda, 1.0);
        let p = path_error(&[[0.0, 0.0, 1.0], [3.0, 4.0, 0.0]], &[[0.0; 3], [0.0; 3]]);
        assert_eq!(p.max, 5.0);
        assert!((p.rms - 13f64.sqrt()).abs() < 1e-15);
    }
}
