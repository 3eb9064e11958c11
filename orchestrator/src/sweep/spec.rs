//! The sweep file: a base scenario plus axes, validated once into a [`SweepSpec`] whose
//! cases are fixed before anything runs (so shards of one sweep agree on every case).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use fmi2_md::Shown;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, Uniform};
use serde::Deserialize;
use toml::Spanned;

use crate::scenario::{
    first_repeat, has_top_level_key, line_of, path_hint, read_text, toml_message,
};

/// A sweep-file problem: file, line (when known) and message.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}{}: {message}", file.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct SweepSpecError {
    pub file: PathBuf,
    pub line: Option<usize>,
    pub message: String,
}

/// Most cases one sweep may hold; a typo in a grid should not plan a billion campaigns.
pub const MAX_CASES: usize = 1_000_000;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSweep {
    base: Spanned<String>,
    #[serde(default)]
    trials: Option<Spanned<usize>>,
    #[serde(default)]
    combine: Option<Spanned<String>>,
    #[serde(default)]
    seed: u64,
    #[serde(default)]
    record: bool,
    #[serde(rename = "axis")]
    axes: Vec<Spanned<RawAxis>>,
    #[serde(default)]
    seeds: Option<Spanned<RawSeeds>>,
    #[serde(default)]
    report: Option<RawReport>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAxis {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    parameters: Vec<String>,
    #[serde(default)]
    memory: Option<String>,
    #[serde(default)]
    setting: Option<String>,
    #[serde(default)]
    scale: bool,
    #[serde(default)]
    values: Option<Vec<toml::Value>>,
    #[serde(default)]
    labels: Option<Vec<String>>,
    #[serde(default)]
    linspace: Option<(f64, f64, usize)>,
    #[serde(default)]
    logspace: Option<(f64, f64, usize)>,
    #[serde(default)]
    uniform: Option<(f64, f64)>,
    #[serde(default)]
    normal: Option<(f64, f64)>,
    #[serde(default)]
    lhs: Option<(f64, f64)>,
    #[serde(default)]
    samples: Option<usize>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSeeds {
    parameter: String,
    #[serde(default)]
    base: i64,
    #[serde(default = "default_stride")]
    stride: i64,
    #[serde(default)]
    per_trial: Option<i64>,
}

fn default_stride() -> i64 {
    1_000_000
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawReport {
    #[serde(default)]
    threshold: Option<Spanned<f64>>,
}

/// What an axis changes in the base scenario.
#[derive(Debug, Clone, PartialEq)]
pub enum Target {
    /// FMU parameters `fmu.name` (several move together, e.g. both friction terms).
    Parameters(Vec<(String, String)>),
    /// A key of the `[memory.update]` table of the channel whose `to` is `channel`;
    /// `setting = "update"` replaces the whole table (an empty table removes it).
    Memory { channel: String, setting: String },
}

/// One axis: its column name, target, whether values scale the base value, and its values
/// in case order (after combination they are per case, see [`SweepSpec::cases`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    pub name: String,
    pub target: Target,
    pub scale: bool,
    pub values: Vec<toml::Value>,
    /// Text for each value in tables and figures (a label, or the value itself).
    pub labels: Vec<String>,
    /// Whether the values are numbers (plotted on an axis) rather than categories.
    pub numeric: bool,
    /// Whether the values form a grid (not random draws): heatmaps need two grid axes.
    pub grid: bool,
    /// Line of the axis in the sweep file.
    pub line: Option<usize>,
    /// How the values were made, for the report (e.g. "lhs [0.7, 1.3], 16 draws").
    pub source: String,
}

/// Per-case seeds: `parameter` gets `base + case·stride`, as a per-trial value
/// `{ base, per_trial }` when `per_trial` is set (or replacing the `base` of a per-trial value
/// the base scenario gives it).
#[derive(Debug, Clone, PartialEq)]
pub struct Seeds {
    pub fmu: String,
    pub parameter: String,
    pub base: i64,
    pub stride: i64,
    /// Step of a per-trial value `{ base, per_trial }` set for the case (fresh noise in
    /// every trial); `None` sets one value for the whole case.
    pub per_trial: Option<i64>,
}

/// How axes combine into cases.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Combine {
    /// Every combination, the first axis varying slowest.
    Product,
    /// Case i takes value i of every axis (all axes equally long).
    Zip,
}

/// A validated sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepSpec {
    pub source: PathBuf,
    /// The sweep file's text, part of the sweep's fingerprint.
    pub text: String,
    pub base: PathBuf,
    pub base_text: String,
    pub trials: Option<usize>,
    pub record: bool,
    pub combine: Combine,
    pub axes: Vec<Axis>,
    pub seeds: Option<Seeds>,
    /// Max-error level, m, whose final-trial fraction the report gives. Default 5e-5 (0.05 mm).
    pub threshold: f64,
    /// Value index of every axis for every case.
    pub cases: Vec<Vec<usize>>,
}

impl SweepSpec {
    /// Reads and validates a sweep file and its base scenario's text (the scenario itself is
    /// validated per case, against the FMUs).
    pub fn load(file: &Path) -> Result<SweepSpec, SweepSpecError> {
        let text = read_text(file).map_err(|e| SweepSpecError {
            file: file.to_path_buf(),
            line: None,
            message: format!("cannot read the sweep file: {e}"),
        })?;
        Self::parse(&text, file)
    }

    /// Validates sweep `text` read from `file`.
    pub fn parse(text: &str, file: &Path) -> Result<SweepSpec, SweepSpecError> {
        let err = |span: std::ops::Range<usize>, message: String| SweepSpecError {
            file: file.to_path_buf(),
            line: (span.end > 0).then(|| line_of(text, span.start)),
            message,
        };
        let raw: RawSweep = toml::from_str(text).map_err(|e| {
            let mut message = toml_message(&e, text);
            if has_top_level_key(text, &["fmu", "connection", "step_size"]) {
                message += " (this is a scenario: `orchestrator run` runs it, and a sweep file \
                            names it as its `base`)";
            }
            SweepSpecError {
                file: file.to_path_buf(),
                line: e.span().map(|s| line_of(text, s.start)),
                message,
            }
        })?;
        let base = file
            .parent()
            .unwrap_or(Path::new("."))
            .join(raw.base.get_ref());
        let base_text = read_text(&base).map_err(|e| {
            err(
                raw.base.span(),
                format!(
                    "cannot read the base scenario {}: {e}{}",
                    base.display(),
                    path_hint(raw.base.get_ref(), &base)
                ),
            )
        })?;
        let base_doc: toml::Table = toml::from_str(&base_text).map_err(|e| {
            err(
                raw.base.span(),
                format!("base scenario {}: {}", base.display(), e.message()),
            )
        })?;
        // The cases are compared by their leg errors, which only [metrics] measures.
        if !base_doc.contains_key("metrics") {
            return Err(err(
                raw.base.span(),
                format!(
                    "the base scenario {} has no [metrics]: a sweep compares its cases by \
                     their leg errors",
                    base.display()
                ),
            ));
        }
        if let Some(t) = &raw.trials
            && *t.get_ref() == 0
        {
            return Err(err(t.span(), "trials must be at least 1".into()));
        }
        let combine = match raw.combine.as_ref().map(|c| c.get_ref().as_str()) {
            None | Some("product") => Combine::Product,
            Some("zip") => Combine::Zip,
            Some(other) => {
                let span = raw.combine.as_ref().map(Spanned::span).unwrap_or(0..0);
                return Err(err(
                    span,
                    format!("combine = {other:?}: use \"product\" or \"zip\""),
                ));
            }
        };
        if raw.axes.is_empty() {
            return Err(err(0..0, "no [[axis]] entries".into()));
        }
        let fmu_names = fmu_names(&base_doc);
        let channels = memory_channels(&base_doc);
        let mut axes: Vec<Axis> = Vec::new();
        let mut names = BTreeSet::new();
        for (i, a) in raw.axes.iter().enumerate() {
            let mut axis = build_axis(a.get_ref(), raw.seed, i, &fmu_names, &channels)
                .map_err(|m| err(a.span(), format!("axis {}: {m}", i + 1)))?;
            axis.line = Some(line_of(text, a.span().start));
            for (j, other) in axes.iter().enumerate() {
                if let Some(what) = overlap(other, &axis) {
                    return Err(err(
                        a.span(),
                        format!(
                            "axis {} ({:?}) and axis {} ({:?}, line {}) both set {what}: \
                             a case would take one value and report both",
                            i + 1,
                            axis.name,
                            j + 1,
                            other.name,
                            other.line.unwrap_or(0)
                        ),
                    ));
                }
            }
            if !names.insert(axis.name.clone()) {
                return Err(err(
                    a.span(),
                    format!("axis {}: the name {:?} is used twice", i + 1, axis.name),
                ));
            }
            axes.push(axis);
        }
        let lens: Vec<usize> = axes.iter().map(|a| a.values.len()).collect();
        let cases = match combine {
            Combine::Zip => {
                if lens.iter().any(|&n| n != lens[0]) {
                    let span = raw.combine.as_ref().map(Spanned::span).unwrap_or(0..0);
                    return Err(err(
                        span,
                        format!("combine = \"zip\" needs axes of one length; they have {lens:?}"),
                    ));
                }
                (0..lens[0]).map(|i| vec![i; lens.len()]).collect()
            }
            Combine::Product => {
                // Grid axes combine with each other; random axes are one Monte Carlo
                // sample together (draw j of every random axis is one plant variant), and
                // that sample combines with the grids.
                let mut factors: Vec<Vec<usize>> = Vec::new();
                let mut random: Option<usize> = None;
                for (a, axis) in axes.iter().enumerate() {
                    if axis.grid {
                        factors.push(vec![a]);
                    } else if let Some(f) = random {
                        if lens[a] != lens[factors[f][0]] {
                            return Err(err(
                                raw.axes[a].span(),
                                format!(
                                    "random axes are drawn together and need one `samples`; \
                                     {:?} has {} and {:?} has {}",
                                    axes[factors[f][0]].name,
                                    lens[factors[f][0]],
                                    axis.name,
                                    lens[a]
                                ),
                            ));
                        }
                        factors[f].push(a);
                    } else {
                        random = Some(factors.len());
                        factors.push(vec![a]);
                    }
                }
                let sizes: Vec<usize> = factors.iter().map(|f| lens[f[0]]).collect();
                let mut total = 1usize;
                for (f, &n) in factors.iter().zip(&sizes) {
                    // The line of the axis that takes the product past the limit.
                    total = total
                        .checked_mul(n)
                        .filter(|&t| t <= MAX_CASES)
                        .ok_or_else(|| {
                            err(
                                raw.axes[f[0]].span(),
                                format!(
                                    "axis {}: its {n} values times the {total} cases of the axes \
                                     before it make more than {MAX_CASES} cases",
                                    f[0] + 1
                                ),
                            )
                        })?;
                }
                (0..total)
                    .map(|mut c| {
                        let mut idx = vec![0; lens.len()];
                        for (f, &n) in factors.iter().zip(&sizes).rev() {
                            for &a in f {
                                idx[a] = c % n;
                            }
                            c /= n;
                        }
                        idx
                    })
                    .collect()
            }
        };
        let seeds = match &raw.seeds {
            None => None,
            Some(s) => {
                let r = s.get_ref();
                let (fmu, parameter) = split_target(&r.parameter, &fmu_names)
                    .map_err(|m| err(s.span(), format!("seeds: {m}")))?;
                if r.stride == 0 {
                    return Err(err(s.span(), "seeds.stride must not be 0".into()));
                }
                let seeded = (fmu.clone(), parameter.clone());
                if let Some((j, axis)) = axes.iter().enumerate().find(
                    |(_, a)| matches!(&a.target, Target::Parameters(ps) if ps.contains(&seeded)),
                ) {
                    return Err(err(
                        s.span(),
                        format!(
                            "[seeds] parameter = {:?} is also set by axis {} ({:?}, line {}): \
                             the seed would overwrite the axis's values",
                            r.parameter,
                            j + 1,
                            axis.name,
                            axis.line.unwrap_or(0)
                        ),
                    ));
                }
                Some(Seeds {
                    fmu,
                    parameter,
                    base: r.base,
                    stride: r.stride,
                    per_trial: r.per_trial,
                })
            }
        };
        let (threshold, span) = raw
            .report
            .and_then(|r| r.threshold)
            .map_or((5e-5, 0..0), |t| (*t.get_ref(), t.span()));
        if !(threshold.is_finite() && threshold > 0.0) {
            return Err(err(
                span,
                format!("report.threshold = {} must be positive", Shown(threshold)),
            ));
        }
        Ok(SweepSpec {
            source: file.to_path_buf(),
            text: text.to_string(),
            base,
            base_text,
            trials: raw.trials.map(Spanned::into_inner),
            record: raw.record,
            combine,
            axes,
            seeds,
            threshold,
            cases,
        })
    }

    /// Labels of case `i`, one per axis.
    pub fn case_labels(&self, i: usize) -> Vec<&str> {
        self.axes
            .iter()
            .zip(&self.cases[i])
            .map(|(a, &v)| a.labels[v].as_str())
            .collect()
    }
}

fn fmu_names(doc: &toml::Table) -> Vec<String> {
    doc.get("fmu")
        .and_then(toml::Value::as_array)
        .map(|a| {
            a.iter()
                .filter_map(|f| f.get("name")?.as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default()
}

fn memory_channels(doc: &toml::Table) -> Vec<String> {
    doc.get("memory")
        .and_then(toml::Value::as_array)
        .map(|a| {
            a.iter()
                .filter_map(|m| m.get("to")?.as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default()
}

/// `fmu.parameter` → (fmu, parameter), the FMU being one the base scenario names.
fn split_target(target: &str, fmus: &[String]) -> Result<(String, String), String> {
    let Some((fmu, name)) = target.split_once('.') else {
        return Err(format!(
            "{target:?} is not of the form \"fmu.parameter\" (e.g. \"plant.platform_mass\")"
        ));
    };
    if !fmus.iter().any(|f| f == fmu) {
        return Err(format!(
            "{target:?}: the base scenario has no FMU {fmu:?} (it has {fmus:?})"
        ));
    }
    if name.is_empty() {
        return Err(format!("{target:?} names no parameter"));
    }
    Ok((fmu.to_string(), name.to_string()))
}

/// What an axis and a later one both set in a case's scenario, if anything: the later
/// would silently replace the earlier's value while sweep.csv reports both. An `update`
/// table replaces every setting of its channel that an earlier axis made; a later setting
/// axis only adds to the table, unless one of the update values already holds that key.
fn overlap(earlier: &Axis, later: &Axis) -> Option<String> {
    match (&earlier.target, &later.target) {
        (Target::Parameters(x), Target::Parameters(y)) => x
            .iter()
            .find(|p| y.contains(p))
            .map(|(fmu, name)| format!("{fmu}.{name}")),
        (
            Target::Memory {
                channel,
                setting: first,
            },
            Target::Memory {
                channel: c2,
                setting: second,
            },
        ) if channel == c2 => {
            let in_update_values = first == "update"
                && earlier
                    .values
                    .iter()
                    .any(|v| v.as_table().is_some_and(|t| t.contains_key(second)));
            if first == second || in_update_values {
                Some(format!("the {second} of memory channel {channel:?}"))
            } else if second == "update" {
                Some(format!(
                    "the {first} of memory channel {channel:?} (setting = \"update\" replaces \
                     the whole [memory.update] table)"
                ))
            } else {
                None
            }
        }
        _ => None,
    }
}

/// Keys of the `[memory.update]` table an axis may set.
const MEMORY_SETTINGS: [&str; 7] = [
    "update",
    "filter",
    "order",
    "cutoff",
    "lead",
    "forgetting",
    "gain",
];

fn build_axis(
    a: &RawAxis,
    seed: u64,
    index: usize,
    fmus: &[String],
    channels: &[String],
) -> Result<Axis, String> {
    let target = match (&a.memory, a.parameters.is_empty()) {
        (Some(_), false) => return Err("give either `parameters` or `memory`, not both".into()),
        (None, true) => return Err("give `parameters = [\"fmu.name\", ...]` or `memory`".into()),
        (None, false) => {
            let ps: Vec<(String, String)> = a
                .parameters
                .iter()
                .map(|p| split_target(p, fmus))
                .collect::<Result<_, _>>()?;
            // A scaled parameter listed twice would be scaled twice.
            if let Some((_, k)) = first_repeat(&ps) {
                return Err(format!("{:?} is listed twice", a.parameters[k]));
            }
            Target::Parameters(ps)
        }
        (Some(ch), true) => {
            if !channels.iter().any(|c| c == ch) {
                return Err(format!(
                    "the base scenario has no [[memory]] channel to {ch:?} (it has {channels:?})"
                ));
            }
            let setting = a
                .setting
                .clone()
                .ok_or("a memory axis needs `setting` (e.g. \"cutoff\")")?;
            if !MEMORY_SETTINGS.contains(&setting.as_str()) {
                return Err(format!(
                    "setting = {setting:?} is not one of {MEMORY_SETTINGS:?}"
                ));
            }
            Target::Memory {
                channel: ch.clone(),
                setting,
            }
        }
    };
    if a.setting.is_some() && a.memory.is_none() {
        return Err("`setting` belongs to a memory axis".into());
    }
    let sources = [
        a.values.is_some(),
        a.linspace.is_some(),
        a.logspace.is_some(),
        a.uniform.is_some(),
        a.normal.is_some(),
        a.lhs.is_some(),
    ];
    if sources.iter().filter(|&&s| s).count() != 1 {
        return Err(
            "give exactly one of values, linspace, logspace, uniform, normal or lhs".into(),
        );
    }
    let random = a.uniform.is_some() || a.normal.is_some() || a.lhs.is_some();
    if a.samples.is_some() && !random {
        return Err("`samples` belongs to a random axis (uniform, normal, lhs)".into());
    }
    let samples = || -> Result<usize, String> {
        match a.samples {
            Some(n) if n > MAX_CASES => Err(format!(
                "samples = {n} would make more than {MAX_CASES} cases"
            )),
            Some(n) if n >= 1 => Ok(n),
            Some(_) => Err("samples must be at least 1".into()),
            None => Err("a random axis needs `samples`".into()),
        }
    };
    let finite = |xs: &[f64]| -> Result<(), String> {
        match xs.iter().find(|x| !x.is_finite()) {
            Some(x) => Err(format!("{x} is not a finite number")),
            None => Ok(()),
        }
    };
    // Each axis draws from its own stream, so adding an axis leaves the others' draws alone.
    let mut rng =
        ChaCha8Rng::seed_from_u64(seed ^ (index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
    let numbers: Option<Vec<f64>> = if let Some((lo, hi, n)) = a.linspace {
        finite(&[lo, hi])?;
        grid_len(n)?;
        Some(linspace(lo, hi, n))
    } else if let Some((lo, hi, n)) = a.logspace {
        finite(&[lo, hi])?;
        grid_len(n)?;
        Some(
            linspace(lo, hi, n)
                .into_iter()
                .map(|e| 10f64.powf(e))
                .collect(),
        )
    } else if let Some((lo, hi)) = a.uniform {
        finite(&[lo, hi])?;
        let n = samples()?;
        let d = Uniform::new_inclusive(lo, hi)
            .map_err(|e| format!("uniform [{}, {}]: {e}", Shown(lo), Shown(hi)))?;
        Some((0..n).map(|_| d.sample(&mut rng)).collect())
    } else if let Some((mean, sd)) = a.normal {
        finite(&[mean, sd])?;
        // rand_distr takes a negative σ as |σ|; a typo there must not run a sweep.
        if sd < 0.0 {
            return Err(format!(
                "normal [{}, {}]: the standard deviation must not be negative",
                Shown(mean),
                Shown(sd)
            ));
        }
        let n = samples()?;
        let d = Normal::new(mean, sd)
            .map_err(|e| format!("normal({}, {}): {e}", Shown(mean), Shown(sd)))?;
        Some((0..n).map(|_| d.sample(&mut rng)).collect())
    } else if let Some((lo, hi)) = a.lhs {
        finite(&[lo, hi])?;
        if hi < lo {
            return Err(format!(
                "lhs [{}, {}]: the upper bound is below the lower",
                Shown(lo),
                Shown(hi)
            ));
        }
        let n = samples()?;
        // Latin hypercube: one draw in each of n equal strata, in a random order; with zip,
        // independent orders per axis make the joint design a Latin hypercube.
        let mut strata: Vec<usize> = (0..n).collect();
        strata.shuffle(&mut rng);
        let u = Uniform::new(0.0, 1.0).map_err(|e| e.to_string())?;
        Some(
            strata
                .into_iter()
                .map(|s| lo + (hi - lo) * (s as f64 + u.sample(&mut rng)) / n as f64)
                .collect(),
        )
    } else {
        None
    };
    // Finite bounds can still give points or draws beyond a double (a span of ±1.7e308, a
    // power of 10 above 1e308): named here, at the axis, not as a case's refused scenario.
    if let Some((i, x)) = numbers
        .iter()
        .flatten()
        .enumerate()
        .find(|(_, x)| !x.is_finite())
    {
        return Err(format!(
            "its value {} is {x}: the range overflows a double; narrow it",
            i + 1
        ));
    }
    let source = if let Some((lo, hi, n)) = a.linspace {
        format!("linspace [{}, {}], {n} points", Shown(lo), Shown(hi))
    } else if let Some((lo, hi, n)) = a.logspace {
        format!("logspace [1e{lo}, 1e{hi}], {n} points")
    } else if let Some((lo, hi)) = a.uniform {
        format!(
            "uniform [{}, {}], {} draws",
            Shown(lo),
            Shown(hi),
            a.samples.unwrap_or(0)
        )
    } else if let Some((mean, sd)) = a.normal {
        format!(
            "normal (mean {}, sd {}), {} draws",
            Shown(mean),
            Shown(sd),
            a.samples.unwrap_or(0)
        )
    } else if let Some((lo, hi)) = a.lhs {
        format!(
            "Latin hypercube [{}, {}], {} draws",
            Shown(lo),
            Shown(hi),
            a.samples.unwrap_or(0)
        )
    } else {
        String::new()
    };
    let (values, numeric) = match numbers {
        Some(xs) => (xs.into_iter().map(toml::Value::Float).collect(), true),
        None => {
            let vs = a.values.clone().unwrap_or_default();
            if vs.is_empty() {
                return Err("values is empty".into());
            }
            let numeric = vs
                .iter()
                .all(|v| matches!(v, toml::Value::Float(_) | toml::Value::Integer(_)));
            for v in &vs {
                if let toml::Value::Float(x) = v
                    && !x.is_finite()
                {
                    return Err(format!("value {x} is not finite"));
                }
            }
            (vs, numeric)
        }
    };
    if a.scale {
        if !numeric {
            return Err("scale = true needs numeric values".into());
        }
        if !matches!(target, Target::Parameters(_)) {
            return Err("scale = true applies to FMU parameters".into());
        }
    }
    let labels = match &a.labels {
        Some(l) if l.len() != values.len() => {
            return Err(format!("{} labels for {} values", l.len(), values.len()));
        }
        Some(l) => {
            if let Some((i, j)) = first_repeat(l) {
                return Err(format!(
                    "labels lists {:?} twice (values {} and {}): each value needs its own",
                    l[j],
                    i + 1,
                    j + 1
                ));
            }
            l.clone()
        }
        None => axis_labels(&values),
    };
    let name = a.name.clone().unwrap_or_else(|| match &target {
        Target::Parameters(ps) => ps
            .iter()
            .map(|(f, p)| format!("{f}.{p}"))
            .collect::<Vec<_>>()
            .join("+"),
        Target::Memory { channel, setting } => format!("{channel}.{setting}"),
    });
    if name.is_empty() || name.contains([',', '"', '\n']) {
        return Err(format!(
            "axis name {name:?} must be non-empty, without commas or quotes"
        ));
    }
    if is_result_column(&name) {
        return Err(format!(
            "axis name {name:?} is a column sweep.csv already has (case, {}, max_k, rms_k); \
             choose another",
            RESULT_COLUMNS.join(", ")
        ));
    }
    Ok(Axis {
        name,
        target,
        scale: a.scale,
        values,
        labels,
        numeric,
        grid: !random,
        line: None,
        source,
    })
}

/// The columns of `sweep.csv` after the case number and the axes (then `max_k` and
/// `rms_k` for each trial k).
pub(crate) const RESULT_COLUMNS: [&str; 7] = [
    "verdict",
    "trials",
    "best",
    "best_trial",
    "final",
    "trials_to_10pct",
    "trials_to_1pct",
];

/// Whether an axis of this name would repeat one of `sweep.csv`'s own columns.
fn is_result_column(name: &str) -> bool {
    let per_trial = ["max_", "rms_"].iter().any(|p| {
        name.strip_prefix(p)
            .is_some_and(|k| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()))
    });
    name == "case" || RESULT_COLUMNS.contains(&name) || per_trial
}

/// Refuses empty grids, and grids too long to make cases of before they are allocated.
fn grid_len(n: usize) -> Result<(), String> {
    if n == 0 {
        Err("a grid needs at least one point".into())
    } else if n > MAX_CASES {
        Err(format!("{n} points would make more than {MAX_CASES} cases"))
    } else {
        Ok(())
    }
}

/// `n` points from `lo` to `hi` inclusive, as numpy's `linspace`.
fn linspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n == 1 {
        return vec![lo];
    }
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}

/// An axis's values as text for tables and figures, numbers in shortest round-trip form.
/// Where one of the axis's numbers needs an exponent (`1e-6`), every non-zero one is written
/// with one, so that a column does not read `1e-6` beside `0.00001`.
fn axis_labels(values: &[toml::Value]) -> Vec<String> {
    let exponent = values.iter().any(|v| match v {
        toml::Value::Float(x) => Shown(*x).to_string().contains('e'),
        _ => false,
    });
    values
        .iter()
        .map(|v| match v {
            toml::Value::Float(x) if exponent && *x != 0.0 && x.is_finite() => format!("{x:e}"),
            v => value_label(v),
        })
        .collect()
}

/// Compact text of a value for tables: numbers in shortest round-trip form.
fn value_label(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        toml::Value::Float(x) => Shown(*x).to_string(),
        toml::Value::Integer(i) => i.to_string(),
        toml::Value::Boolean(b) => b.to_string(),
        other => other.to_string().replace('\n', " "),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sweep files shipped in `scenarios/` load: their axes and their base scenarios'
    /// text are valid (each case's scenario is checked against the FMUs when it runs).
    #[test]
    fn the_shipped_sweep_files_load() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios");
        let expected = [
            ("line-noise-sweep.toml", 9, Some(50)),
            ("robustness-sweep.toml", 96, Some(20)),
        ];
        let mut found: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter(|n| n.ends_with("-sweep.toml"))
            .collect();
        found.sort();
        let names: Vec<&str> = expected.iter().map(|e| e.0).collect();
        assert_eq!(found, names, "a shipped sweep file without its check here");
        for (name, cases, trials) in expected {
            let spec = SweepSpec::load(&dir.join(name)).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(spec.cases.len(), cases, "{name}");
            assert_eq!(spec.trials, trials, "{name}");
        }
    }

    fn spec(sweep: &str) -> Result<SweepSpec, SweepSpecError> {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("base.toml"),
            "step_size = 0.001\nstop_time = 1.0\n[[fmu]]\nname = \"plant\"\npath = \"p.fmu\"\n\
             [[fmu]]\nname = \"controller\"\npath = \"c.fmu\"\n\
             [[memory]]\nfrom = \"controller.memory_next\"\nto = \"controller.memory\"\n\
             [metrics]\nerror = \"controller.error\"\n",
        )
        .unwrap();
        std::fs::write(dir.path().join("unmeasured.toml"), "step_size = 0.001\n").unwrap();
        let file = dir.path().join("sweep.toml");
        SweepSpec::parse(sweep, &file)
    }

    #[test]
    fn product_orders_cases_with_the_first_axis_slowest() {
        let s = spec(
            "base = \"base.toml\"\n[[axis]]\nparameters = [\"plant.rod_mass\"]\nvalues = [1.0, 2.0]\n\
             [[axis]]\nmemory = \"controller.memory\"\nsetting = \"cutoff\"\nlinspace = [5.0, 10.0, 3]\n",
        )
        .unwrap();
        assert_eq!(s.cases.len(), 6);
        assert_eq!(s.cases[0], vec![0, 0]);
        assert_eq!(s.cases[1], vec![0, 1]);
        assert_eq!(s.cases[5], vec![1, 2]);
        assert_eq!(s.axes[1].labels, vec!["5", "7.5", "10"]);
    }

    /// One number of an axis written with an exponent puts every non-zero one in that form.
    #[test]
    fn an_axis_writes_its_numbers_in_one_form() {
        let labels = |values: &str| {
            let text = format!(
                "base = \"base.toml\"\n[[axis]]\nparameters = [\"plant.rod_mass\"]\nvalues = {values}\n"
            );
            spec(&text).unwrap().axes[0].labels.clone()
        };
        assert_eq!(labels("[0.0, 1e-6, 1e-5]"), vec!["0", "1e-6", "1e-5"]);
        assert_eq!(
            labels("[2.5e-7, 0.001, 3.0]"),
            vec!["2.5e-7", "1e-3", "3e0"]
        );
        assert_eq!(labels("[0.00001, 0.5]"), vec!["0.00001", "0.5"]);
    }

    #[test]
    fn random_axes_form_one_sample_that_combines_with_the_grids() {
        let s = spec(
            "base = \"base.toml\"\n[[axis]]\nparameters = [\"plant.rod_mass\"]\nvalues = [1.0, 2.0]\n\
             [[axis]]\nparameters = [\"plant.gravity\"]\nuniform = [9.0, 10.0]\nsamples = 3\n\
             [[axis]]\nparameters = [\"plant.cylinder_mass\"]\nnormal = [10.0, 1.0]\nsamples = 3\n",
        )
        .unwrap();
        assert_eq!(s.cases.len(), 6);
        assert!(s.cases.iter().all(|c| c[1] == c[2]), "{:?}", s.cases);
        assert_eq!(s.cases[3], vec![1, 0, 0]);
        let e = spec(
            "base = \"base.toml\"\n[[axis]]\nparameters = [\"plant.gravity\"]\nuniform = [9.0, 10.0]\nsamples = 3\n\
             [[axis]]\nparameters = [\"plant.cylinder_mass\"]\nnormal = [10.0, 1.0]\nsamples = 4\n",
        )
        .unwrap_err();
        assert!(e.message.contains("one `samples`"), "{e}");
    }

    #[test]
    fn latin_hypercube_puts_one_draw_in_every_stratum() {
        let s = spec(
            "base = \"base.toml\"\ncombine = \"zip\"\nseed = 7\n[[axis]]\nparameters = [\"plant.rod_mass\"]\n\
             lhs = [0.0, 1.0]\nsamples = 20\n",
        )
        .unwrap();
        let mut strata: Vec<usize> = s.axes[0]
            .values
            .iter()
            .map(|v| (v.as_float().unwrap() * 20.0).floor() as usize)
            .collect();
        strata.sort_unstable();
        assert_eq!(strata, (0..20).collect::<Vec<_>>());
        // The same seed draws the same design.
        let again = spec(
            "base = \"base.toml\"\ncombine = \"zip\"\nseed = 7\n[[axis]]\nparameters = [\"plant.rod_mass\"]\n\
             lhs = [0.0, 1.0]\nsamples = 20\n",
        )
        .unwrap();
        assert_eq!(s.axes[0].values, again.axes[0].values);
    }

    #[test]
    fn two_keys_setting_one_variable_are_refused_naming_both() {
        let mass = "[[axis]]\nname = \"mass\"\nparameters = [\"plant.rod_mass\"]\nvalues = [1.0]\n";
        let e = spec(&format!(
            "base = \"base.toml\"\n{mass}[[axis]]\nname = \"m2\"\n\
             parameters = [\"plant.gravity\", \"plant.rod_mass\"]\nvalues = [2.0]\n"
        ))
        .unwrap_err();
        assert_eq!(e.line, Some(6), "{e}");
        assert!(
            e.message
                .contains("axis 2 (\"m2\") and axis 1 (\"mass\", line 2) both set plant.rod_mass"),
            "{e}"
        );
        let e = spec(
            "base = \"base.toml\"\n[[axis]]\nparameters = [\"plant.rod_mass\", \"plant.rod_mass\"]\n\
             values = [1.0]\n",
        )
        .unwrap_err();
        assert!(e.message.contains("listed twice"), "{e}");
        let e = spec(
            "base = \"base.toml\"\n[[axis]]\nparameters = [\"plant.noise_seed\"]\nvalues = [1, 2]\n\
             [seeds]\nparameter = \"plant.noise_seed\"\n",
        )
        .unwrap_err();
        assert_eq!(e.line, Some(5), "{e}");
        assert!(
            e.message
                .contains("[seeds] parameter = \"plant.noise_seed\" is also set by axis 1"),
            "{e}"
        );
        assert!(e.message.contains("line 2"), "{e}");
        let memory = |setting: &str, values: &str| {
            format!(
                "[[axis]]\nmemory = \"controller.memory\"\nsetting = \"{setting}\"\nvalues = {values}\n"
            )
        };
        let robust = "[{ filter = \"butterworth\", order = 2, cutoff = 8.0 }]";
        for (first, second) in [
            (memory("cutoff", "[1.0]"), memory("update", "[{}]")),
            (memory("update", robust), memory("cutoff", "[1.0]")),
            (memory("lead", "[1]"), memory("lead", "[2]")),
        ] {
            let e = spec(&format!("base = \"base.toml\"\n{first}{second}")).unwrap_err();
            assert_eq!(e.line, Some(6), "{first}{second}: {e}");
            assert!(e.message.contains("both set the"), "{e}");
        }
        // A setting the update values leave alone may follow them.
        spec(&format!(
            "base = \"base.toml\"\n{}{}",
            memory("update", robust),
            memory("lead", "[1]")
        ))
        .unwrap();
        // Different settings of one channel, and one parameter's axis with the seeds of another,
        // are fine.
        spec(&format!(
            "base = \"base.toml\"\n{}{}{mass}[seeds]\nparameter = \"plant.noise_seed\"\n",
            memory("cutoff", "[1.0]"),
            memory("lead", "[1]")
        ))
        .unwrap();
    }

    #[test]
    fn bad_axes_name_the_line() {
        let cases = [
            (
                "[[axis]]\nparameters = [\"robot.mass\"]\nvalues = [1.0]\n",
                "no FMU \"robot\"",
            ),
            (
                "[[axis]]\nparameters = [\"plant.rod_mass\"]\nvalues = []\n",
                "values is empty",
            ),
            (
                "[[axis]]\nparameters = [\"plant.rod_mass\"]\nuniform = [0.0, 1.0]\n",
                "needs `samples`",
            ),
            (
                "[[axis]]\nmemory = \"controller.x\"\nsetting = \"cutoff\"\nvalues = [1.0]\n",
                "no [[memory]] channel",
            ),
            (
                "[[axis]]\nmemory = \"controller.memory\"\nsetting = \"cutof\"\nvalues = [1.0]\n",
                "is not one of",
            ),
            (
                "[[axis]]\nparameters = [\"plant.rod_mass\"]\nvalues = [1.0]\nlinspace = [0.0, 1.0, 2]\n",
                "exactly one",
            ),
            (
                "[[axis]]\nparameters = [\"plant.rod_mass\"]\nnormal = [1.0, -0.1]\nsamples = 3\n",
                "must not be negative",
            ),
            // Finite bounds whose points overflow: named at the axis (they were refused as
            // case 0's scenario, "forgetting = NaN").
            (
                "[[axis]]\nmemory = \"controller.memory\"\nsetting = \"forgetting\"\n\
                 linspace = [-1.7e308, 1.7e308, 3]\n",
                "axis 1: its value 1 is NaN: the range overflows a double; narrow it",
            ),
            (
                "[[axis]]\nmemory = \"controller.memory\"\nsetting = \"gain\"\n\
                 logspace = [300, 309, 3]\n",
                "axis 1: its value 3 is inf: the range overflows a double",
            ),
            (
                "[[axis]]\nmemory = \"controller.memory\"\nsetting = \"gain\"\n\
                 lhs = [-1.7e308, 1.7e308]\nsamples = 3\n",
                "the range overflows a double",
            ),
            // The distribution's own refusal, its bounds shown short (not 309 digits).
            (
                "[[axis]]\nmemory = \"controller.memory\"\nsetting = \"gain\"\n\
                 uniform = [-1.7e308, 1.7e308]\nsamples = 3\n",
                "uniform [-1.7e308, 1.7e308]: ",
            ),
        ];
        for (axis, want) in cases {
            let e = spec(&format!("base = \"base.toml\"\n{axis}")).unwrap_err();
            assert_eq!(e.line, Some(2), "{axis}: {e}");
            assert!(e.message.contains(want), "{axis}: {e}");
        }
        let e = spec(
            "base = \"base.toml\"\n[[axis]]\nparameters = [\"plant.rod_mass\"]\n\
             uniform = [0.5, 1.5]\nsamples = 1000000000000\n",
        )
        .unwrap_err();
        assert_eq!(e.line, Some(2), "{e}");
        assert!(e.message.contains("more than 1000000 cases"), "{e}");
        let e = spec(
            "base = \"base.toml\"\n[[axis]]\nparameters = [\"plant.rod_mass\"]\n\
             linspace = [0.5, 1.5, 1000000000000]\n",
        )
        .unwrap_err();
        assert!(e.message.contains("more than 1000000 cases"), "{e}");
        let e = spec(
            "base = \"unmeasured.toml\"\n[[axis]]\nparameters = [\"plant.rod_mass\"]\nvalues = [1.0]\n",
        )
        .unwrap_err();
        assert_eq!(e.line, Some(1));
        assert!(e.message.contains("has no [metrics]"), "{e}");
        let e = spec("base = \"missing.toml\"\n[[axis]]\nparameters = [\"plant.rod_mass\"]\nvalues = [1.0]\n")
            .unwrap_err();
        assert_eq!(e.line, Some(1));
        assert!(e.message.contains("cannot read the base scenario"), "{e}");
        // Neither hint for a plain missing path (both begin " (the ").
        assert!(!e.message.contains(" (the "), "{e}");
        // `\f` read as a form feed, and a path written as for a shell, are explained.
        let e = spec("base = \"C:\\fmus\\b.toml\"\n[[axis]]\nparameters = [\"plant.rod_mass\"]\nvalues = [1.0]\n")
            .unwrap_err();
        assert!(e.message.contains("holds a control character"), "{e}");
        let e = spec(
            "base = \"~/b.toml\"\n[[axis]]\nparameters = [\"plant.rod_mass\"]\nvalues = [1.0]\n",
        )
        .unwrap_err();
        assert!(e.message.contains("not expanded"), "{e}");
        let e = spec("base = \"base.toml\"\ncombine = \"zip\"\n[[axis]]\nparameters = [\"plant.rod_mass\"]\nvalues = [1.0]\n\
                      [[axis]]\nparameters = [\"plant.gravity\"]\nvalues = [1.0, 2.0]\n")
            .unwrap_err();
        assert!(e.message.contains("one length"), "{e}");
    }
}
