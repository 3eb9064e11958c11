//! `info X.fmu`: what a user needs to know before simulating or connecting an FMU: identity,
//! co-simulation capabilities, default experiment, log categories and a table of variables.
//!
//! The FMU is opened fully (unpacked, validated, binary loaded), so `info` also tells whether
//! it would run here: when only its binary fails (none for this platform, or one that does
//! not load), the description is still shown and the exit status is the failure's, so that a
//! user on one platform can read an FMU built for another.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use fmi2_import::Fmu;
use fmi2_md::{
    Initial, ModelDescription, ScalarVariable, SimpleTypeKind, VariableKind,
    VariableNamingConvention, printable,
};

use crate::args::InfoArgs;

/// Runs `info`.
pub fn run(args: InfoArgs) -> Result<()> {
    let (text, failed) = match Fmu::open(&args.fmu) {
        Ok(fmu) => (
            describe(fmu.path(), fmu.model_description(), &fmu.platforms(), true),
            None,
        ),
        Err(e) if e.is_binary_problem() => {
            let (md, platforms) = fmi2_import::read_description(&args.fmu)
                .map_err(|e| super::simulate::open_error(&args.fmu, &e))?;
            (describe(&args.fmu, &md, &platforms, false), Some(e))
        }
        Err(e) => return Err(super::simulate::open_error(&args.fmu, &e)),
    };
    let written = orchestrator::output::to_stdout(|w| w.write_all(text.as_bytes()))
        .context("cannot write to standard output");
    match failed {
        // The FMU's own problem is the answer; a lost description is only a warning then.
        Some(e) => {
            if let Err(w) = written {
                orchestrator::console!("warning: {}", orchestrator::describe(&*w));
            }
            Err(super::simulate::open_error(&args.fmu, &e))
        }
        None => written,
    }
}

/// The whole report as text, for the FMU at `path`; `runs_here` says whether its binary for
/// this platform loaded.
fn describe(path: &Path, md: &ModelDescription, platforms: &[String], runs_here: bool) -> String {
    let mut out = String::new();
    // Writing into a String cannot fail; the `let _ =` below discard that impossible error.
    let _ = writeln!(out, "{}", printable(&path.display().to_string()));
    let mut identity = vec![
        ("Model", md.model_name.clone()),
        ("FMI version", md.fmi_version.clone()),
        ("GUID", md.guid.clone()),
    ];
    let optional = [
        ("Description", &md.description),
        ("Version", &md.version),
        ("Author", &md.author),
        ("Generation tool", &md.generation_tool),
        ("Generated", &md.generation_date_and_time),
    ];
    identity.extend(
        optional
            .into_iter()
            .filter_map(|(k, v)| v.as_ref().map(|v| (k, v.clone()))),
    );
    identity.push((
        "Variable naming",
        match md.variable_naming_convention {
            VariableNamingConvention::Flat => "flat",
            VariableNamingConvention::Structured => "structured",
        }
        .to_owned(),
    ));
    identity.push(("Platforms", platforms_shown(platforms, runs_here)));
    out.push_str(&key_values("", &identity));

    out.push('\n');
    if let Some(cs) = &md.co_simulation {
        let _ = writeln!(
            out,
            "Co-Simulation (modelIdentifier {})",
            printable(&cs.model_identifier)
        );
        let flags = [
            (
                "canHandleVariableCommunicationStepSize",
                cs.can_handle_variable_communication_step_size,
            ),
            ("canInterpolateInputs", cs.can_interpolate_inputs),
            ("canRunAsynchronuously", cs.can_run_asynchronuously),
            ("canGetAndSetFMUstate", cs.can_get_and_set_fmu_state),
            ("canSerializeFMUstate", cs.can_serialize_fmu_state),
            (
                "providesDirectionalDerivative",
                cs.provides_directional_derivative,
            ),
            ("needsExecutionTool", cs.needs_execution_tool),
            (
                "canBeInstantiatedOnlyOncePerProcess",
                cs.can_be_instantiated_only_once_per_process,
            ),
            (
                "canNotUseMemoryManagementFunctions",
                cs.can_not_use_memory_management_functions,
            ),
        ];
        let mut pairs: Vec<(&str, String)> = flags
            .iter()
            .map(|&(k, v)| (k, if v { "yes" } else { "no" }.to_owned()))
            .collect();
        pairs.push((
            "maxOutputDerivativeOrder",
            cs.max_output_derivative_order.to_string(),
        ));
        out.push_str(&key_values("  ", &pairs));
    }
    match &md.model_exchange {
        Some(me) => {
            let _ = writeln!(
                out,
                "Model Exchange (modelIdentifier {}): offered, not used by this tool",
                printable(&me.model_identifier)
            );
        }
        None => out.push_str("Model Exchange: not offered\n"),
    }

    out.push('\n');
    let _ = writeln!(out, "Default experiment: {}", default_experiment(md));

    if !md.log_categories.is_empty() {
        out.push_str("\nLog categories\n");
        let pairs: Vec<(&str, String)> = md
            .log_categories
            .iter()
            .map(|c| (c.name.as_str(), c.description.clone().unwrap_or_default()))
            .collect();
        out.push_str(&key_values("  ", &pairs));
    }

    let enumerations: Vec<_> = md
        .type_definitions
        .iter()
        .filter_map(|t| match &t.kind {
            SimpleTypeKind::Enumeration { items, .. } => Some((t, items)),
            _ => None,
        })
        .collect();
    if !enumerations.is_empty() {
        out.push_str("\nEnumerations\n");
        for (t, items) in enumerations {
            let list: Vec<String> = items
                .iter()
                .map(|i| format!("{} = {}", i.value, printable(&i.name)))
                .collect();
            let _ = writeln!(out, "  {}: {}", printable(&t.name), list.join(", "));
        }
    }

    let _ = writeln!(out, "\nVariables ({})", md.model_variables.len());
    let header = [
        "name",
        "vr",
        "type",
        "causality",
        "variability",
        "initial",
        "start",
        "unit",
        "range",
        "description",
    ];
    let rows: Vec<Vec<String>> = md
        .model_variables
        .iter()
        .map(|v| variable_row(md, v))
        .collect();
    out.push_str(&table("  ", &header, &rows));
    out
}

/// The `binaries/` subdirectories present in the archive, and whether one runs here (as
/// every value of [`key_values`], escaped there).
fn platforms_shown(platforms: &[String], runs_here: bool) -> String {
    let here = fmi2_import::PLATFORM;
    let listed = if platforms.is_empty() {
        "none".to_owned()
    } else {
        platforms.join(", ")
    };
    if runs_here {
        format!("{listed} (running here as {here})")
    } else {
        format!("{listed} (cannot run here, on {here}: see the error below)")
    }
}

/// `start 0 s, stop 2 s, step 0.001 s, tolerance not given`.
fn default_experiment(md: &ModelDescription) -> String {
    let Some(de) = &md.default_experiment else {
        return "none".to_owned();
    };
    let show = |v: Option<f64>, unit: &str| {
        v.map_or_else(|| "not given".to_owned(), |x| format!("{x}{unit}"))
    };
    format!(
        "start {}, stop {}, step {}, tolerance {}",
        show(de.start_time, " s"),
        show(de.stop_time, " s"),
        show(de.step_size, " s"),
        show(de.tolerance, ""),
    )
}

/// One line of the variable table.
fn variable_row(md: &ModelDescription, v: &ScalarVariable) -> Vec<String> {
    let (type_name, start, unit) = match &v.kind {
        VariableKind::Real {
            declared_type,
            unit,
            start,
            ..
        } => {
            let unit = unit.clone().or_else(|| {
                let t = md.simple_type(declared_type.as_deref()?)?;
                match &t.kind {
                    SimpleTypeKind::Real { unit, .. } => unit.clone(),
                    _ => None,
                }
            });
            (
                "Real".to_owned(),
                start.map(|x| x.to_string()),
                unit.unwrap_or_default(),
            )
        }
        VariableKind::Integer { start, .. } => (
            "Integer".to_owned(),
            start.map(|n| n.to_string()),
            String::new(),
        ),
        VariableKind::Boolean { start } => (
            "Boolean".to_owned(),
            start.map(|b| b.to_string()),
            String::new(),
        ),
        VariableKind::String { start } => (
            "String".to_owned(),
            start.as_ref().map(|s| format!("{s:?}")),
            String::new(),
        ),
        VariableKind::Enumeration {
            declared_type,
            start,
            ..
        } => {
            let item = |n: i32| {
                md.simple_type(declared_type).and_then(|t| match &t.kind {
                    SimpleTypeKind::Enumeration { items, .. } => {
                        items.iter().find(|i| i.value == n).map(|i| i.name.clone())
                    }
                    _ => None,
                })
            };
            let start = start.map(|n| match item(n) {
                Some(name) => format!("{n} ({name})"),
                None => n.to_string(),
            });
            (format!("Enumeration {declared_type}"), start, String::new())
        }
    };
    vec![
        v.name.clone(),
        v.value_reference.to_string(),
        type_name,
        v.causality.as_str().to_owned(),
        v.variability.as_str().to_owned(),
        v.initial.map_or("", Initial::as_str).to_owned(),
        start.unwrap_or_default(),
        unit,
        range(md, v),
        v.description.clone().unwrap_or_default(),
    ]
}

/// The declared bounds of a Real or Integer (`[0.01, 10]`, `≥ 0`, `≤ 5`), which values set
/// by a master must respect; empty when unbounded. Enumerations show their items instead.
fn range(md: &ModelDescription, v: &ScalarVariable) -> String {
    if !matches!(
        v.kind,
        VariableKind::Real { .. } | VariableKind::Integer { .. }
    ) {
        return String::new();
    }
    match md.range_of(v) {
        (Some(lo), Some(hi)) => format!("[{lo}, {hi}]"),
        (Some(lo), None) => format!("≥ {lo}"),
        (None, Some(hi)) => format!("≤ {hi}"),
        (None, None) => String::new(),
    }
}

/// `key   value` lines with the values aligned.
fn key_values(indent: &str, pairs: &[(&str, String)]) -> String {
    let width = pairs
        .iter()
        .map(|(k, _)| printable(k).chars().count())
        .max()
        .unwrap_or(0);
    let mut out = String::new();
    for (k, v) in pairs {
        let k = printable(k);
        let _ = writeln!(out, "{indent}{k:<width$}  {}", printable(v));
    }
    out
}

/// A left-aligned text table; the last column is not padded, so long descriptions do not
/// push trailing spaces onto every line.
fn table(indent: &str, header: &[&str], rows: &[Vec<String>]) -> String {
    let rows: Vec<Vec<String>> = rows
        .iter()
        .map(|r| r.iter().map(|c| printable(c).into_owned()).collect())
        .collect();
    let mut widths: Vec<usize> = header.iter().map(|h| h.chars().count()).collect();
    for row in &rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let mut out = String::new();
    let mut line = |cells: &mut dyn Iterator<Item = &str>| {
        let mut text = String::from(indent);
        for (i, (cell, &w)) in cells.zip(&widths).enumerate() {
            if i + 1 == widths.len() {
                text.push_str(cell);
            } else {
                let _ = write!(text, "{cell:<w$}  ");
            }
        }
        out.push_str(text.trim_end());
        out.push('\n');
    };
    line(&mut header.iter().copied());
    for row in &rows {
        line(&mut row.iter().map(String::as_str));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_aligns_columns_and_trims_the_last() {
        let rows = vec![
            vec!["x".to_owned(), "1".to_owned(), "first".to_owned()],
            vec!["longer".to_owned(), "22".to_owned(), String::new()],
        ];
        let text = table("  ", &["name", "vr", "description"], &rows);
        assert_eq!(
            text,
            "  name    vr  description\n  x       1   first\n  longer  22\n"
        );
    }

    #[test]
    fn control_characters_are_escaped_everywhere() {
        let rows = vec![vec!["x\u{1b}[2J".to_owned(), "a\nb\\c".to_owned()]];
        let text = table("", &["name", "description"], &rows);
        assert_eq!(
            text,
            "name        description\nx\\u{1b}[2J  a\\u{a}b\\\\c\n"
        );
        assert!(!text.contains('\u{1b}'));
        let kv = key_values("", &[("Model", "m\rX".into())]);
        assert_eq!(kv, "Model  m\\u{d}X\n");
    }

    #[test]
    fn key_values_align() {
        let text = key_values("", &[("a", "1".into()), ("long", "2".into())]);
        assert_eq!(text, "a     1\nlong  2\n");
    }
}
