//! The FMI 2.0 rules a parsed description must follow; every violation is collected.

use std::collections::{BTreeSet, HashMap};

use super::datetime::is_xs_date_time;
use super::*;

/// Collects problems with their element and line.
struct Report(Vec<Problem>);

impl Report {
    fn push(
        &mut self,
        line: Option<usize>,
        element: impl Into<String>,
        message: impl Into<String>,
    ) {
        self.0.push(Problem {
            line,
            element: element.into(),
            message: message.into(),
        });
    }

    fn var(&mut self, v: &ScalarVariable, message: impl Into<String>) {
        self.push(
            v.line,
            format!("ScalarVariable '{}'", printable(&v.name)),
            message,
        );
    }
}

pub(super) fn validate(md: &ModelDescription) -> Vec<Problem> {
    let mut r = Report(md.schema_problems.clone());
    check_header(md, &mut r);
    check_definitions(md, &mut r);
    check_uniqueness(md, &mut r);
    for v in &md.model_variables {
        check_variable(md, v, &mut r);
    }
    check_outputs(md, &mut r);
    check_derivatives(md, &mut r);
    check_initial_unknowns(md, &mut r);
    r.0
}

fn check_header(md: &ModelDescription, r: &mut Report) {
    const ROOT: &str = "fmiModelDescription";
    if md.co_simulation.is_none() {
        r.push(None, ROOT, "no <CoSimulation> element");
    }
    for (element, id) in [
        (
            "CoSimulation",
            md.co_simulation
                .as_ref()
                .map(|c| c.model_identifier.as_str()),
        ),
        (
            "ModelExchange",
            md.model_exchange
                .as_ref()
                .map(|m| m.model_identifier.as_str()),
        ),
    ] {
        if let Some(id) = id {
            if !is_c_identifier(id) {
                r.push(
                    None,
                    element,
                    format!("modelIdentifier '{id}' is not a valid C identifier"),
                );
            }
        }
    }
    if md.model_name.trim().is_empty() {
        r.push(None, ROOT, "modelName is empty");
    }
    if md.guid.trim().is_empty() {
        r.push(None, ROOT, "guid is empty");
    }
    if let Some(date) = &md.generation_date_and_time {
        if !is_xs_date_time(date) {
            r.push(
            None,
            ROOT,
            format!("generationDateAndTime '{date}' is not a valid xs:dateTime (e.g. 2026-01-31T12:00:00Z)"),
        );
        }
    }
    if let Some(de) = &md.default_experiment {
        const DE: &str = "DefaultExperiment";
        if let Some(h) = de.step_size {
            if !(h > 0.0 && h.is_finite()) {
                r.push(None, DE, format!("stepSize must be > 0, is {h}"));
            }
        }
        if let Some(tol) = de.tolerance {
            if !(tol > 0.0 && tol.is_finite()) {
                r.push(None, DE, format!("tolerance must be > 0, is {tol}"));
            }
        }
        if let (Some(t0), Some(t1)) = (de.start_time, de.stop_time) {
            if t1 <= t0 {
                r.push(
                    None,
                    DE,
                    format!("stopTime {t1} must be after startTime {t0}"),
                );
            }
        }
    }
}

fn is_c_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

fn check_definitions(md: &ModelDescription, r: &mut Report) {
    let mut seen = BTreeSet::new();
    for u in &md.unit_definitions {
        if !seen.insert(u.name.as_str()) {
            r.push(None, format!("Unit '{}'", u.name), "defined more than once");
        }
        let mut display = BTreeSet::new();
        for d in &u.display_units {
            if !display.insert(d.name.as_str()) {
                r.push(
                    None,
                    format!("Unit '{}'", u.name),
                    format!("DisplayUnit '{}' defined more than once", d.name),
                );
            }
        }
    }
    let mut seen = BTreeSet::new();
    for t in &md.type_definitions {
        let element = format!("SimpleType '{}'", t.name);
        if !seen.insert(t.name.as_str()) {
            r.push(None, &element, "defined more than once");
        }
        match &t.kind {
            SimpleTypeKind::Real {
                unit,
                display_unit,
                min,
                max,
                ..
            } => {
                check_unit_refs(
                    md,
                    unit.as_deref(),
                    display_unit.as_deref(),
                    None,
                    &element,
                    r,
                );
                check_range(*min, *max, None, None, &element, r);
            }
            SimpleTypeKind::Integer { min, max, .. } => {
                check_range(
                    min.map(f64::from),
                    max.map(f64::from),
                    None,
                    None,
                    &element,
                    r,
                );
            }
            SimpleTypeKind::Enumeration { items, .. } => {
                if items.is_empty() {
                    r.push(None, &element, "enumeration has no items");
                }
                let mut names = BTreeSet::new();
                let mut values = BTreeSet::new();
                for item in items {
                    if !names.insert(item.name.as_str()) {
                        r.push(
                            None,
                            &element,
                            format!("item name '{}' used more than once", item.name),
                        );
                    }
                    if !values.insert(item.value) {
                        r.push(
                            None,
                            &element,
                            format!("item value {} used more than once", item.value),
                        );
                    }
                }
            }
            SimpleTypeKind::Boolean | SimpleTypeKind::String => {}
        }
    }
}

/// Checks that `unit` exists and that `display_unit` is one of its display units;
/// `type_unit` is the unit inherited from a declared type when the variable has none.
fn check_unit_refs(
    md: &ModelDescription,
    unit: Option<&str>,
    display_unit: Option<&str>,
    type_unit: Option<&str>,
    element: &str,
    r: &mut Report,
) {
    let line = None;
    if let Some(u) = unit {
        if md.unit(u).is_none() {
            r.push(
                line,
                element,
                format!("unit '{u}' is not defined in <UnitDefinitions>"),
            );
        }
    }
    if let Some(d) = display_unit {
        match unit.or(type_unit) {
            None => r.push(
                line,
                element,
                format!("displayUnit '{d}' given without a unit"),
            ),
            Some(u) => {
                if let Some(def) = md.unit(u) {
                    if !def.display_units.iter().any(|du| du.name == d) {
                        r.push(
                            line,
                            element,
                            format!("displayUnit '{d}' is not defined for unit '{u}'"),
                        );
                    }
                }
            }
        }
    }
}

fn check_range(
    min: Option<f64>,
    max: Option<f64>,
    start: Option<f64>,
    line: Option<usize>,
    element: &str,
    r: &mut Report,
) {
    if let (Some(lo), Some(hi)) = (min, max) {
        if lo > hi {
            r.push(line, element, format!("min {lo} is greater than max {hi}"));
        }
    }
    if let Some(s) = start {
        if let Some(lo) = min {
            if s < lo {
                r.push(line, element, format!("start {s} is below min {lo}"));
            }
        }
        if let Some(hi) = max {
            if s > hi {
                r.push(line, element, format!("start {s} is above max {hi}"));
            }
        }
    }
}

fn check_uniqueness(md: &ModelDescription, r: &mut Report) {
    let mut names: HashMap<&str, usize> = HashMap::new();
    let mut vrs: HashMap<(VarType, u32), &str> = HashMap::new();
    for (i, v) in md.model_variables.iter().enumerate() {
        let malformed = match md.variable_naming_convention {
            VariableNamingConvention::Flat => super::names::flat_error(&v.name),
            VariableNamingConvention::Structured => super::names::structured_error(&v.name),
        };
        if let Some(why) = malformed {
            r.var(v, why);
        }
        match names.get(v.name.as_str()) {
            Some(first) => r.var(
                v,
                format!("name is already used by variable #{}", first + 1),
            ),
            None => {
                names.insert(v.name.as_str(), i);
            }
        }
        let family = accessor_family(v.var_type());
        match vrs.get(&(family, v.value_reference)) {
            Some(other) => r.var(
                v,
                format!(
                    "valueReference {} is already used by {:?} variable '{other}' (value references must be unique per base type)",
                    v.value_reference, family
                ),
            ),
            None => {
                vrs.insert((family, v.value_reference), v.name.as_str());
            }
        }
    }
}

fn check_variable(md: &ModelDescription, v: &ScalarVariable, r: &mut Report) {
    let (c, var) = (v.causality, v.variability);
    let is_real = v.var_type() == VarType::Real;
    if var == Variability::Continuous && !is_real {
        r.var(
            v,
            format!(
                "variability continuous is only allowed for Real variables, not {:?}",
                v.var_type()
            ),
        );
    }
    match allowed_initials(c, var) {
        None => {
            let why = match c {
                Causality::Parameter | Causality::CalculatedParameter => "must be fixed or tunable",
                Causality::Input => "must be discrete or continuous",
                Causality::Output => "must be constant, discrete or continuous",
                Causality::Independent => "must be continuous",
                Causality::Local => "is not allowed",
            };
            r.var(
                v,
                format!("{} {why} (variability is {})", c.as_str(), var.as_str()),
            );
        }
        Some(rule) => {
            if let Some(i) = v.initial {
                if !rule.allowed.contains(&i) {
                    let allowed = if rule.allowed.is_empty() {
                        "no initial attribute".to_owned()
                    } else {
                        rule.allowed
                            .iter()
                            .map(|&a| a.as_str())
                            .collect::<Vec<_>>()
                            .join(" or ")
                    };
                    r.var(
                    v,
                    format!(
                        "initial={} is not allowed for causality={} variability={} (allowed: {allowed})",
                        i.as_str(),
                        c.as_str(),
                        var.as_str()
                    ),
                );
                }
            }
            check_start(v, r);
        }
    }
    if c == Causality::Independent && !is_real {
        r.var(v, "the independent variable must be Real");
    }
    check_kind(md, v, r);
}

fn check_start(v: &ScalarVariable, r: &mut Report) {
    let has_start = v.has_start();
    match (v.causality, v.initial) {
        (Causality::Input, _) if !has_start => {
            r.var(v, "input has no start value (inputs need one)")
        }
        (Causality::Independent, _) if has_start => {
            r.var(v, "the independent variable must not have a start value")
        }
        (_, Some(i @ (Initial::Exact | Initial::Approx))) if !has_start => {
            r.var(v, format!("initial={} requires a start value", i.as_str()));
        }
        (_, Some(Initial::Calculated)) if has_start => {
            r.var(
                v,
                "has a start value but initial is calculated (start is forbidden)",
            );
        }
        _ => {}
    }
}

/// The declared type's name and definition (`None` if undefined).
fn declared<'a>(
    md: &'a ModelDescription,
    name: &'a Option<String>,
) -> Option<(&'a str, Option<&'a SimpleType>)> {
    name.as_deref().map(|n| (n, md.simple_type(n)))
}

fn check_kind(md: &ModelDescription, v: &ScalarVariable, r: &mut Report) {
    let element = format!("ScalarVariable '{}'", printable(&v.name));
    let wrong_type = |r: &mut Report, n: &str, want: &str| {
        r.var(v, format!("declaredType '{n}' is not a {want} type"));
    };
    let missing_type = |r: &mut Report, n: &str| {
        r.var(
            v,
            format!("declaredType '{n}' is not defined in <TypeDefinitions>"),
        );
    };
    match &v.kind {
        VariableKind::Real {
            declared_type,
            unit,
            display_unit,
            start,
            min,
            max,
            derivative,
            ..
        } => {
            let mut type_unit = None;
            match declared(md, declared_type) {
                Some((n, None)) => missing_type(r, n),
                Some((
                    _,
                    Some(SimpleType {
                        kind: SimpleTypeKind::Real { unit, .. },
                        ..
                    }),
                )) => {
                    type_unit = unit.as_deref();
                }
                Some((n, Some(_))) => wrong_type(r, n, "Real"),
                None => {}
            }
            let before = r.0.len();
            check_unit_refs(
                md,
                unit.as_deref(),
                display_unit.as_deref(),
                type_unit,
                &element,
                r,
            );
            check_range(*min, *max, *start, v.line, &element, r);
            for p in &mut r.0[before..] {
                p.line = v.line;
            }
            if let Some(d) = derivative {
                let index = *d as usize;
                match index.checked_sub(1).and_then(|i| md.model_variables.get(i)) {
                    None => r.var(
                        v,
                        format!(
                            "derivative={d} is not a variable index (1..={})",
                            md.model_variables.len()
                        ),
                    ),
                    Some(state) if state.var_type() != VarType::Real => {
                        r.var(
                            v,
                            format!(
                                "derivative={d} refers to '{}', which is not Real",
                                state.name
                            ),
                        );
                    }
                    Some(_) => {}
                }
            }
        }
        VariableKind::Integer {
            declared_type,
            start,
            min,
            max,
        } => {
            match declared(md, declared_type) {
                Some((n, None)) => missing_type(r, n),
                Some((n, Some(t))) if !matches!(t.kind, SimpleTypeKind::Integer { .. }) => {
                    wrong_type(r, n, "Integer")
                }
                _ => {}
            }
            check_range(
                min.map(f64::from),
                max.map(f64::from),
                start.map(f64::from),
                v.line,
                &element,
                r,
            );
        }
        VariableKind::Enumeration {
            declared_type,
            start,
            min,
            max,
        } => {
            match md.simple_type(declared_type) {
                None => missing_type(r, declared_type),
                Some(SimpleType {
                    kind: SimpleTypeKind::Enumeration { items, .. },
                    ..
                }) => {
                    if let Some(s) = start {
                        if !items.iter().any(|i| i.value == *s) {
                            r.var(
                                v,
                                format!(
                                    "start {s} is not a value of enumeration '{declared_type}'"
                                ),
                            );
                        }
                    }
                }
                Some(_) => wrong_type(r, declared_type, "Enumeration"),
            }
            check_range(
                min.map(f64::from),
                max.map(f64::from),
                start.map(f64::from),
                v.line,
                &element,
                r,
            );
        }
        VariableKind::Boolean { .. } | VariableKind::String { .. } => {}
    }
}

/// Checks one Unknown's index and dependencies; returns the variable it names.
fn check_unknown<'m>(
    md: &'m ModelDescription,
    u: &Unknown,
    section: &str,
    r: &mut Report,
) -> Option<&'m ScalarVariable> {
    let n = md.model_variables.len();
    let element = format!("ModelStructure/{section}");
    if let Some(deps) = &u.dependencies {
        for &d in deps {
            if d == 0 || d > n {
                r.push(
                    u.line,
                    &element,
                    format!(
                        "Unknown index={}: dependency {d} is out of range 1..={n}",
                        u.index
                    ),
                );
            }
        }
        if let Some(kinds) = &u.dependencies_kind {
            if kinds.len() != deps.len() {
                r.push(
                    u.line,
                    &element,
                    format!(
                        "Unknown index={}: {} dependenciesKind for {} dependencies",
                        u.index,
                        kinds.len(),
                        deps.len()
                    ),
                );
            }
        }
    } else if u.dependencies_kind.is_some() {
        r.push(
            u.line,
            &element,
            format!(
                "Unknown index={}: dependenciesKind without dependencies",
                u.index
            ),
        );
    }
    if u.index == 0 || u.index > n {
        r.push(
            u.line,
            &element,
            format!("Unknown index={} is out of range 1..={n}", u.index),
        );
        return None;
    }
    md.model_variables.get(u.index - 1)
}

fn check_outputs(md: &ModelDescription, r: &mut Report) {
    let listed: Vec<usize> = md
        .model_structure
        .outputs
        .iter()
        .filter_map(|u| check_unknown(md, u, "Outputs", r).map(|_| u.index))
        .collect();
    let expected: Vec<usize> = md
        .model_variables
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output)
        .map(|(i, _)| i + 1)
        .collect();
    compare_lists(md, &listed, &expected, "Outputs", "causality=\"output\"", r);
}

fn check_derivatives(md: &ModelDescription, r: &mut Report) {
    for u in &md.model_structure.derivatives {
        if let Some(v) = check_unknown(md, u, "Derivatives", r) {
            if !matches!(
                v.kind,
                VariableKind::Real {
                    derivative: Some(_),
                    ..
                }
            ) {
                r.push(
                    u.line,
                    "ModelStructure/Derivatives",
                    format!(
                        "Unknown index={} ('{}') is not a Real with a derivative attribute",
                        u.index, v.name
                    ),
                );
            }
        }
    }
}

/// FMI 2.0 §2.2.8: InitialUnknowns lists, in ascending index order, exactly the outputs
/// with initial approx/calculated, the calculated parameters, and the state derivatives
/// listed under Derivatives (and their states) with initial approx/calculated.
fn check_initial_unknowns(md: &ModelDescription, r: &mut Report) {
    let listed: Vec<usize> = md
        .model_structure
        .initial_unknowns
        .iter()
        .filter_map(|u| check_unknown(md, u, "InitialUnknowns", r).map(|_| u.index))
        .collect();
    let not_exact =
        |v: &ScalarVariable| matches!(v.initial, Some(Initial::Approx | Initial::Calculated));
    let mut expected = BTreeSet::new();
    for (i, v) in md.model_variables.iter().enumerate() {
        if (v.causality == Causality::Output && not_exact(v))
            || v.causality == Causality::CalculatedParameter
        {
            expected.insert(i + 1);
        }
    }
    for u in &md.model_structure.derivatives {
        let Some(der) = u
            .index
            .checked_sub(1)
            .and_then(|i| md.model_variables.get(i))
        else {
            continue;
        };
        if not_exact(der) {
            expected.insert(u.index);
        }
        if let VariableKind::Real {
            derivative: Some(s),
            ..
        } = der.kind
        {
            let state = (s as usize)
                .checked_sub(1)
                .and_then(|i| md.model_variables.get(i));
            if state.is_some_and(not_exact) {
                expected.insert(s as usize);
            }
        }
    }
    let expected: Vec<usize> = expected.into_iter().collect();
    compare_lists(
        md,
        &listed,
        &expected,
        "InitialUnknowns",
        "outputs with initial approx/calculated, calculated parameters and states/derivatives with initial approx/calculated",
        r,
    );
}

/// Reports variables missing from or extra in a ModelStructure list, and wrong order.
fn compare_lists(
    md: &ModelDescription,
    listed: &[usize],
    expected: &[usize],
    section: &str,
    rule: &str,
    r: &mut Report,
) {
    let element = format!("ModelStructure/{section}");
    let name = |i: usize| md.model_variables[i - 1].name.as_str();
    let listed_set: BTreeSet<usize> = listed.iter().copied().collect();
    let expected_set: BTreeSet<usize> = expected.iter().copied().collect();
    for &i in expected.iter().filter(|i| !listed_set.contains(i)) {
        let v = &md.model_variables[i - 1];
        r.push(
            v.line,
            &element,
            format!(
                "'{}' (index {i}) is missing; {section} must list all {rule}",
                name(i)
            ),
        );
    }
    for &i in listed_set.iter().filter(|i| !expected_set.contains(i)) {
        r.push(
            None,
            &element,
            format!(
                "'{}' (index {i}) must not be listed; {section} lists only {rule}",
                name(i)
            ),
        );
    }
    let mut seen = BTreeSet::new();
    for &i in listed {
        if !seen.insert(i) {
            r.push(
                None,
                &element,
                format!("'{}' (index {i}) is listed more than once", name(i)),
            );
        }
    }
    if listed.windows(2).any(|w| w[0] >= w[1]) && seen.len() == listed.len() {
        r.push(
            None,
            &element,
            "Unknowns must be in ascending index order (the order of ModelVariables)",
        );
    }
}
