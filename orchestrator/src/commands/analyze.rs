//! `analyze SCENARIO.toml`: the frequency-domain convergence analysis of the learning update
//! (docs/convergence.md), from the plant and controller parameters and the memory update of a
//! scenario. Writes convergence.csv, convergence.svg and summary.md; prints the summary.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use ckcm::convergence::{Analysis, Problem, analyse, validate};
use ckcm::learning::{LowPass, UpdateSettings};
use ckcm::{Gains, Mechanism, ParamError, Params, Trajectory, TrajectoryKind};
use fmi2_import::Fmu;
use fmi2_md::{ModelDescription, Shown, VariableKind};
use orchestrator::output::convergence_plot::{ModeCurves, convergence_factor};
use orchestrator::output::{write_atomic, write_table_csv};
use orchestrator::scenario::{FmuSpec, Scenario, Value, describe_update, trajectory_item};

use crate::args::AnalyzeArgs;

/// Runs `analyze`.
pub fn run(args: AnalyzeArgs) -> Result<()> {
    let (scenario, _, fmus) = Scenario::open(&args.scenario)?;
    let problem = problem(&args, &scenario, &fmus)?;
    let analysis = analyse(&problem).with_context(|| format!("{}", args.scenario.display()))?;
    // A factor beyond the largest double says no more than "diverges", and neither the
    // chart nor the table can hold it.
    let worst = &analysis.worst_case.peak;
    if !worst.value.is_finite() {
        bail!(
            "{}: with {}, the convergence factor overflows to {} (at {:.2} Hz, mode {}): \
             learning diverges beyond what can be charted; analyse a smaller gain",
            args.scenario.display(),
            describe_update(&problem.update),
            worst.value,
            worst.frequency,
            worst.mode + 1
        );
    }
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from("results").join(format!(
            "{}-convergence",
            args.scenario
                .file_stem()
                .unwrap_or_default()
                .to_string_lossy()
        ))
    });
    orchestrator::output::create_folder(&out)
        .with_context(|| format!("cannot create {}", out.display()))?;
    let name = args
        .scenario
        .file_name()
        .unwrap_or_default()
        .to_string_lossy();
    let summary = summary(&name, &problem, &analysis);
    let labels: Vec<String> = analysis
        .modes
        .iter()
        .enumerate()
        .map(|(i, m)| {
            format!(
                "mode {} ({:.1}–{:.1} kg)",
                i + 1,
                m.spread.min,
                m.spread.max
            )
        })
        .collect();
    let curves: Vec<ModeCurves<'_>> = analysis
        .modes
        .iter()
        .zip(labels)
        .map(|(m, label)| ModeCurves {
            label,
            filtered: &m.worst,
            unfiltered: &m.unfiltered,
        })
        .collect();
    convergence_factor(
        &out.join("convergence.svg"),
        &format!("Convergence factor per leg-space mode: {name}"),
        &analysis.frequencies,
        &curves,
    )?;
    // The table after the chart, the likelier of the two to fail: a failure leaves the
    // folder's earlier table and summary together.
    write_csv(&out.join("convergence.csv"), &analysis)?;
    write_atomic(&out.join("summary.md"), |w| w.write_all(summary.as_bytes()))?;
    orchestrator::output::to_stdout(|w| w.write_all(summary.as_bytes()))
        .context("cannot write the summary to standard output")?;
    orchestrator::console!("results in {}", out.display());
    Ok(())
}

/// The first memory channel's update (validated with the scenario), then the command-line
/// overrides, checked again.
fn update(args: &AnalyzeArgs, scenario: &Scenario) -> Result<UpdateSettings> {
    let file = &scenario.source;
    let mut u = scenario
        .memory
        .first()
        .and_then(|m| m.update)
        .unwrap_or_default();
    if args.no_filter {
        u.filter = None;
    }
    if let Some(c) = args.cutoff {
        u.filter = Some(LowPass {
            order: u.filter.map_or(4, |q| q.order),
            cutoff_hz: c,
        });
    }
    if let Some(o) = args.order {
        match &mut u.filter {
            Some(q) => q.order = o,
            None => bail!("--order needs a cutoff (--cutoff, or cutoff in [memory.update])"),
        }
    }
    if let Some(l) = args.lead {
        u.lead = l;
    }
    if let Some(a) = args.forgetting {
        u.forgetting = a;
    }
    if let Some(g) = args.gain {
        u.gain = g;
    }
    // The options given, so that a value from the command line is not blamed on the file.
    let given: Vec<String> = [
        ("--cutoff", args.cutoff.map(|c| Shown(c).to_string())),
        ("--order", args.order.map(|o| o.to_string())),
        ("--lead", args.lead.map(|l| l.to_string())),
        (
            "--forgetting",
            args.forgetting.map(|a| Shown(a).to_string()),
        ),
        ("--gain", args.gain.map(|g| Shown(g).to_string())),
    ]
    .into_iter()
    .filter_map(|(option, value)| value.map(|v| format!("{option} {v}")))
    .collect();
    validate(&u, scenario.step_size).with_context(|| {
        if given.is_empty() {
            format!("{}: memory update", file.display())
        } else {
            format!("{}: memory update with {}", file.display(), given.join(" "))
        }
    })?;
    if u.lead >= scenario.steps {
        bail!(
            "{}: lead = {} samples must be below the {} samples of a trial",
            file.display(),
            u.lead,
            scenario.steps
        );
    }
    Ok(u)
}

/// Start values of `md` overridden by the scenario's settings of `spec`, as numbers
/// (Integer and Enumeration as their value, Boolean as 0/1).
fn values(md: &ModelDescription, spec: &FmuSpec) -> BTreeMap<String, f64> {
    let mut v = BTreeMap::new();
    for sv in &md.model_variables {
        let start = match &sv.kind {
            VariableKind::Real { start, .. } => *start,
            VariableKind::Integer { start, .. } | VariableKind::Enumeration { start, .. } => {
                start.map(f64::from)
            }
            VariableKind::Boolean { start } => start.map(|b| f64::from(u8::from(b))),
            VariableKind::String { .. } => None,
        };
        if let Some(s) = start {
            v.insert(sv.name.clone(), s);
        }
    }
    for s in &spec.settings {
        let x = match s.value {
            Value::Real(x) => x,
            Value::Integer(i) => f64::from(i),
            Value::Boolean(b) => f64::from(u8::from(b)),
            // The mechanism has no text parameters.
            Value::String(_) => continue,
        };
        v.insert(s.name.clone(), x);
    }
    v
}

/// The plant's mechanism: every field of `ckcm::Params` from the plant variable of that
/// name, which must exist (a parameter renamed in the XML is an error, never a default).
fn plant_params(values: &BTreeMap<String, f64>) -> Result<Params> {
    let mut p = Params::default();
    for field in Params::FIELDS {
        let x = values
            .get(field)
            .with_context(|| format!("has no parameter {field} (a mechanism parameter)"))?;
        p.set_field(field, *x)?;
    }
    Ok(p)
}

/// The controller's nominal model: `Params::nominal()` with each `model.*` variable set,
/// as the controller FMU builds it; a `model.*` name that is no mechanism field is an error.
fn nominal_params(values: &BTreeMap<String, f64>) -> Result<Params> {
    let mut p = Params::nominal();
    for (name, &x) in values {
        if let Some(field) = name.strip_prefix("model.") {
            p.set_field(field, x).map_err(|e| ParamError {
                field: name.clone(),
                ..e
            })?;
        }
    }
    Ok(p)
}

/// Finds the FMU whose model is `model` (the analysis models the CKCM FMUs only). Of
/// several (a scenario of two loops), the first is analysed, and the user is told which.
fn find<'a>(
    scenario: &'a Scenario,
    fmus: &'a [Fmu],
    model: &str,
) -> Result<(&'a FmuSpec, &'a ModelDescription)> {
    let mut all = scenario
        .fmus
        .iter()
        .zip(fmus)
        .map(|(s, f)| (s, f.model_description()))
        .filter(|(_, md)| md.model_name == model);
    let first = all.next().with_context(|| {
        format!(
            "{}: no {model} FMU; the analysis models the CkcmPlant and HlcsController FMUs",
            scenario.source.display()
        )
    })?;
    let others: Vec<String> = all.map(|(s, _)| format!("{:?}", s.name)).collect();
    if !others.is_empty() {
        orchestrator::console!(
            "warning: {}: the analysis models one loop: of the {model} FMUs it takes the \
             first, {:?}, not {}",
            scenario.source.display(),
            first.0.name,
            others.join(", ")
        );
    }
    Ok(first)
}

fn problem(args: &AnalyzeArgs, scenario: &Scenario, fmus: &[Fmu]) -> Result<Problem> {
    let file = &scenario.source;
    let (plant_spec, plant_md) = find(scenario, fmus, "CkcmPlant")?;
    let (ctrl_spec, ctrl_md) = find(scenario, fmus, "HlcsController")?;
    if scenario.memory.is_empty() {
        bail!("{}: no [[memory]] channel: nothing learns", file.display());
    }
    let plant_values = values(plant_md, plant_spec);
    let ctrl = values(ctrl_md, ctrl_spec);
    let plant = plant_params(&plant_values)
        .and_then(|p| Ok(Mechanism::new(p)?))
        .with_context(|| format!("{}: FMU {:?}", file.display(), plant_spec.name))?;
    let nominal = nominal_params(&ctrl)
        .and_then(|p| Ok(Mechanism::new(p)?))
        .with_context(|| format!("{}: FMU {:?}", file.display(), ctrl_spec.name))?;
    let get = |name: &str| -> Result<f64> {
        ctrl.get(name).copied().with_context(|| {
            format!(
                "{}: FMU {:?} has no parameter {name}",
                file.display(),
                ctrl_spec.name
            )
        })
    };
    if get("learning")? == 0.0 {
        bail!(
            "{}: FMU {:?} has learning = false: nothing learns",
            file.display(),
            ctrl_spec.name
        );
    }
    let scale = args.gain_scale;
    if !(scale.is_finite() && scale > 0.0) {
        bail!("--gain-scale = {scale} must be positive");
    }
    let gains = Gains {
        kp: get("kp")?,
        ki: get("ki")?,
        kd: get("kd")?,
        phi: get("phi")? * scale,
        gamma: get("gamma")? * scale,
        psi: get("psi")? * scale,
    };
    for (name, value) in [("Φ", gains.phi), ("Γ", gains.gamma), ("Ψ", gains.psi)] {
        if !value.is_finite() {
            bail!(
                "--gain-scale = {} makes the learning gain {name} overflow to {value}",
                Shown(scale)
            );
        }
    }
    let trajectory = get("trajectory")? as i32;
    let Some(kind) = trajectory_item(ctrl_md, trajectory) else {
        bail!(
            "{}: FMU {:?} has trajectory = {trajectory}: the analysis needs the controller's \
             own reference ({}), not an external one",
            file.display(),
            ctrl_spec.name,
            TrajectoryKind::names()
        );
    };
    let duration = get("duration")?;
    if !(duration.is_finite() && duration > 0.0) {
        bail!(
            "{}: FMU {:?} has duration = {} s; it must be positive",
            file.display(),
            ctrl_spec.name,
            Shown(duration)
        );
    }
    // A dwell of 0 is the frozen worst case; a stride of 0 samples nothing.
    if !(args.dwell.is_finite() && args.dwell >= 0.0) {
        bail!("--dwell = {} s must be zero or positive", Shown(args.dwell));
    }
    if !(args.stride.is_finite() && args.stride > 0.0) {
        bail!("--stride = {} s must be positive", Shown(args.stride));
    }
    if duration / args.stride > ckcm::convergence::MAX_POSES {
        bail!(
            "--stride = {} s samples more than {:e} poses along the {} s reference; \
             use at least {:e} s",
            Shown(args.stride),
            ckcm::convergence::MAX_POSES,
            Shown(duration),
            duration / ckcm::convergence::MAX_POSES
        );
    }
    let update = update(args, scenario)?;
    Ok(Problem {
        plant,
        trajectory: Trajectory {
            kind,
            duration,
            home_height: nominal.params.geometry.home_height,
        },
        gains,
        h: scenario.step_size,
        update,
        stride: args.stride,
        dwell: args.dwell,
        search_order: 4,
    })
}

fn write_csv(path: &Path, a: &Analysis) -> Result<()> {
    let mut header = vec!["frequency_hz".to_string(), "q_gain_sq".to_string()];
    for i in 1..=a.modes.len() {
        header.push(format!("mode{i}_worst"));
        header.push(format!("mode{i}_sustained"));
        header.push(format!("mode{i}_unfiltered"));
    }
    let rows: Vec<Vec<String>> = a
        .frequencies
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let mut row = vec![format!("{f:.6e}"), format!("{:.6e}", a.q_gain_sq[k])];
            for m in &a.modes {
                row.push(format!("{:.6e}", m.worst[k]));
                row.push(format!("{:.6e}", m.sustained_factor[k]));
                row.push(format!("{:.6e}", m.unfiltered[k]));
            }
            row
        })
        .collect();
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    write_table_csv(path, &header, &rows)?;
    Ok(())
}

fn cutoff_text(c: Option<f64>, h: f64) -> String {
    match c {
        None => "none (fails even at the lowest cutoff tried)".to_string(),
        Some(c) if c >= 0.5 / h * 0.999 => "no filter needed".to_string(),
        Some(c) => format!("{c:.2} Hz"),
    }
}

/// A convergence factor to three decimals, or with an exponent once that would be a long
/// row of digits (huge gains give factors of 1e150 and more).
fn factor(x: f64) -> String {
    if x.abs() < 1e6 {
        format!("{x:.3}")
    } else {
        format!("{x:.3e}")
    }
}

/// The markdown summary.
fn summary(name: &str, p: &Problem, a: &Analysis) -> String {
    let g = &p.gains;
    let mut s = String::new();
    let _ = writeln!(s, "# Convergence analysis: {name}\n");
    let _ = writeln!(
        s,
        "- Update: {}; h = {} s, zero-order hold.",
        describe_update(&p.update),
        Shown(p.h)
    );
    let _ = writeln!(
        s,
        "- Feedback Kp {}, Ki {}, Kd {}; learning Φ {}, Γ {}, Ψ {}; viscous friction {} N·s/m.",
        Shown(g.kp),
        Shown(g.ki),
        Shown(g.kd),
        Shown(g.phi),
        Shown(g.gamma),
        Shown(g.psi),
        Shown(p.plant.params.friction.viscous)
    );
    let _ = writeln!(
        s,
        "- Path: {}, {} s, poses every {} s; sustained = held for at least {} s.\n",
        p.trajectory.kind.name(),
        Shown(p.trajectory.duration),
        Shown(p.stride),
        Shown(p.dwell)
    );
    let _ = writeln!(s, "## Leg-space modes along the path\n");
    let _ = writeln!(
        s,
        "| mode | min kg | max kg | heaviest at t [s] | pose there (x, y, z m) | sustained kg |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for (i, m) in a.modes.iter().enumerate() {
        let sp = &m.spread;
        let _ = writeln!(
            s,
            "| {} | {:.2} | {:.2} | {:.3} | ({:.3}, {:.3}, {:.3}) | {:.2} |",
            i + 1,
            sp.min,
            sp.max,
            sp.time_of_max,
            sp.pose_of_max[0],
            sp.pose_of_max[1],
            sp.pose_of_max[2],
            m.sustained
        );
    }
    let _ = writeln!(s, "\n## Verdict\n");
    for (label, v) in [
        ("Prediction (sustained masses)", &a.sustained),
        (
            "Frozen worst case (every pose, conservative)",
            &a.worst_case,
        ),
    ] {
        let _ = writeln!(
            s,
            "- {label}: **{}**; peak factor {} at {:.2} Hz (mode {}).",
            if v.converges() {
                "converges"
            } else {
                "diverges"
            },
            factor(v.peak.value),
            v.peak.frequency,
            v.peak.mode + 1
        );
    }
    let _ = writeln!(s, "\n## Without the filter (same lead, α, g)\n");
    if a.unfiltered_bands.is_empty() {
        let _ = writeln!(s, "- The factor stays ≤ 1 at every frequency.");
    } else {
        let bands: Vec<String> = a
            .unfiltered_bands
            .iter()
            .map(|(lo, hi)| format!("{lo:.2}–{hi:.2} Hz"))
            .collect();
        let _ = writeln!(s, "- Learning diverges in {}.", bands.join(", "));
    }
    let order = p.update.filter.map_or(p.search_order, |q| q.order);
    let _ = writeln!(
        s,
        "\n## Largest safe cutoff (order {order}, lead {})\n",
        p.update.lead
    );
    let _ = writeln!(
        s,
        "- Prediction (sustained masses): {}.",
        cutoff_text(a.sustained.max_safe_cutoff, p.h)
    );
    let _ = writeln!(
        s,
        "- Frozen worst case: {}.",
        cutoff_text(a.worst_case.max_safe_cutoff, p.h)
    );
    s
}
