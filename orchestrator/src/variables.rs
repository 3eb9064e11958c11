//! FMI variables by name, shared by scenario files and `simulate`: one resolver of structured
//! names, one value type, one rule for what a master may set, and one check of a value
//! against its declaration, so that a name or a value means the same wherever it is written.

use fmi2_import::Status;
use fmi2_import::{ImportError, Instance};
use fmi2_md::{Causality, Shown, Variability};
use fmi2_md::{Initial, Item, ModelDescription, ScalarVariable, SimpleTypeKind, VariableKind};

/// A value of a variable's base type.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Real(f64),
    /// Integer and Enumeration.
    Integer(i32),
    Boolean(bool),
    String(String),
}

/// A variable as a master addresses it, for telling whether two assignments set the same
/// one: value references are unique per base type only, so the value's type is the other
/// half (Integer and Enumeration share one, as they share fmi2SetInteger).
pub type VariableKey = (u32, std::mem::Discriminant<Value>);

/// The [`VariableKey`] of the variable `vr` given `value`.
pub fn variable_key(vr: u32, value: &Value) -> VariableKey {
    (vr, std::mem::discriminant(value))
}

/// A value as a user wrote it, before it is converted to a variable's type.
#[derive(Debug, Clone, Copy)]
pub enum Literal<'a> {
    /// Text from the command line or a CSV cell.
    Text(&'a str),
    /// A value of a TOML file.
    Toml(&'a toml::Value),
}

impl std::fmt::Display for Literal<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Literal::Text(t) => f.write_str(t.trim()),
            Literal::Toml(toml::Value::String(s)) => f.write_str(s),
            Literal::Toml(v) => write!(f, "{v}"),
        }
    }
}

/// Index tuple of an array element `base[i]` or `base[i,j,…]` (FMI 2.0 §2.2.9 structured
/// names); `None` for any other name, including records inside an element (`base[1].x`).
fn element_index(base: &str, name: &str) -> Option<Vec<usize>> {
    let inner = name
        .strip_prefix(base)?
        .strip_prefix('[')?
        .strip_suffix(']')?;
    inner.split(',').map(|i| i.trim().parse().ok()).collect()
}

/// The variables `name` denotes: the one with exactly that name, else every element
/// `name[i]` (or `name[i,j]`) of an array in index order, so `force` is `force[1]` to
/// `force[6]`. Empty if there is none.
pub fn resolve<'a>(md: &'a ModelDescription, name: &str) -> Vec<&'a ScalarVariable> {
    if let Some(v) = md.variable_by_name(name) {
        return vec![v];
    }
    let mut elements: Vec<(Vec<usize>, &ScalarVariable)> = md
        .model_variables
        .iter()
        .filter_map(|v| element_index(name, &v.name).map(|i| (i, v)))
        .collect();
    elements.sort_by(|a, b| a.0.cmp(&b.0));
    elements.into_iter().map(|(_, v)| v).collect()
}

/// Why `name` resolves to nothing, with up to five similar names.
pub fn no_such_variable(md: &ModelDescription, name: &str) -> String {
    let lower = name.to_lowercase();
    let similar: Vec<&str> = md
        .model_variables
        .iter()
        .map(|v| v.name.as_str())
        .filter(|n| !lower.is_empty() && n.to_lowercase().contains(&lower))
        .take(5)
        .collect();
    let hint = if similar.is_empty() {
        "`orchestrator info` lists its variables".to_owned()
    } else {
        format!("similar names: {}", similar.join(", "))
    };
    format!(
        "model '{}' has no variable named '{name}' ({hint})",
        md.model_name
    )
}

/// Whether FMI 2.0 lets a master give `var` a value before initialization: inputs, and
/// non-constant variables whose `initial` is exact or approx (FMI 2.0 §4.2.4, the table of
/// allowed calls).
pub fn settable(var: &ScalarVariable) -> Result<(), String> {
    let name = &var.name;
    if var.variability == Variability::Constant {
        return Err(format!("'{name}' is a constant and cannot be set"));
    }
    match var.causality {
        Causality::Input => Ok(()),
        Causality::Independent => Err(format!("'{name}' is the independent variable (time)")),
        _ if matches!(var.initial, Some(Initial::Exact | Initial::Approx)) => Ok(()),
        c => Err(format!(
            "'{name}' is {} and computed by the FMU (initial = calculated), so it has no start value to set",
            causality_phrase(c)
        )),
    }
}

/// "a parameter", "an input", … for messages.
pub fn causality_phrase(c: Causality) -> &'static str {
    match c {
        Causality::Parameter => "a parameter",
        Causality::CalculatedParameter => "a calculated parameter",
        Causality::Input => "an input",
        Causality::Output => "an output",
        Causality::Local => "a local variable",
        Causality::Independent => "the independent variable",
    }
}

/// The items of an Enumeration variable's declared type.
fn enumeration_items<'a>(md: &'a ModelDescription, declared_type: &str) -> Option<&'a [Item]> {
    md.simple_type(declared_type).and_then(|st| match &st.kind {
        SimpleTypeKind::Enumeration { items, .. } => Some(items.as_slice()),
        _ => None,
    })
}

/// An i32 written as an integer or as an integral number (`3.0`, as some tools export).
pub fn parse_integer(t: &str) -> Option<i32> {
    t.parse::<i32>().ok().or_else(|| integral(t.parse().ok()?))
}

fn integral(x: f64) -> Option<i32> {
    let ok = x.fract() == 0.0 && x >= f64::from(i32::MIN) && x <= f64::from(i32::MAX);
    ok.then_some(x as i32)
}

/// `literal` read as a number (text as written, a TOML integer or float), whatever its type.
fn as_number(literal: Literal<'_>) -> Option<f64> {
    match literal {
        Literal::Text(t) => t.trim().parse::<f64>().ok(),
        Literal::Toml(toml::Value::Float(x)) => Some(*x),
        Literal::Toml(toml::Value::Integer(i)) => Some(*i as f64),
        Literal::Toml(_) => None,
    }
}

/// Converts `literal` to `var`'s type: a finite number for Real; an integral number for
/// Integer; true/false (on the command line also 1/0) for Boolean; an item name or value for
/// Enumeration; any text for String. Errors say what was written and what `var` takes.
pub fn convert(
    md: &ModelDescription,
    var: &ScalarVariable,
    literal: Literal<'_>,
) -> Result<Value, String> {
    use toml::Value as T;
    let name = &var.name;
    // A number in quotes is TOML text: `"1.0"` would otherwise be told it is no number.
    let quoted_number = |kind: &str| match literal {
        Literal::Toml(T::String(s)) if s.trim().parse::<f64>().is_ok() => Some(format!(
            "\"{s}\" is quoted, so it is text, not a number: write it without quotes \
             ('{name}' is {kind})"
        )),
        _ => None,
    };
    match &var.kind {
        VariableKind::Real { .. } => as_number(literal)
            .filter(|x| x.is_finite())
            .map(Value::Real)
            .ok_or_else(|| {
                quoted_number("a Real").unwrap_or_else(|| {
                    format!("'{literal}' is not a finite number ('{name}' is a Real)")
                })
            }),
        VariableKind::Integer { .. } => match literal {
            Literal::Text(t) => parse_integer(t.trim()),
            Literal::Toml(T::Integer(i)) => i32::try_from(*i).ok(),
            Literal::Toml(T::Float(x)) => integral(*x),
            Literal::Toml(_) => None,
        }
        .map(Value::Integer)
        .ok_or_else(|| {
            let whole = as_number(literal).is_some_and(|x| x.is_finite() && x.fract() == 0.0);
            if let Some(quoted) = quoted_number("an Integer") {
                quoted
            } else if whole {
                format!(
                    "'{literal}' is out of range: '{name}' is an Integer, from {} to {}",
                    i32::MIN,
                    i32::MAX
                )
            } else {
                format!("'{literal}' is not an integer ('{name}' is an Integer)")
            }
        }),
        VariableKind::Boolean { .. } => match literal {
            Literal::Text(t) => match t.trim() {
                "true" | "1" => Some(true),
                "false" | "0" => Some(false),
                _ => None,
            },
            Literal::Toml(T::Boolean(b)) => Some(*b),
            _ => None,
        }
        .map(Value::Boolean)
        .ok_or_else(|| {
            format!("'{literal}' is not a Boolean ('{name}' is a Boolean: use true or false)")
        }),
        VariableKind::Enumeration { declared_type, .. } => {
            let items = enumeration_items(md, declared_type);
            let number = match literal {
                Literal::Text(t) => parse_integer(t.trim()),
                Literal::Toml(T::Integer(i)) => i32::try_from(*i).ok(),
                Literal::Toml(_) => None,
            };
            let item_name = match literal {
                Literal::Text(t) => Some(t.trim()),
                Literal::Toml(T::String(s)) => Some(s.as_str()),
                Literal::Toml(_) => None,
            };
            let found = match (number, items) {
                (Some(n), Some(items)) => items.iter().any(|i| i.value == n).then_some(n),
                (Some(n), None) => Some(n),
                (None, items) => items
                    .zip(item_name)
                    .and_then(|(items, t)| items.iter().find(|i| i.name == t))
                    .map(|i| i.value),
            };
            found.map(Value::Integer).ok_or_else(|| {
                let choices = items.map_or_else(String::new, |items| {
                    items
                        .iter()
                        .map(|i| format!("{} ({})", i.name, i.value))
                        .collect::<Vec<_>>()
                        .join(", ")
                });
                format!(
                    "'{literal}' is not an item of enumeration {declared_type} ('{name}' takes one of: {choices})"
                )
            })
        }
        VariableKind::String { .. } => match literal {
            Literal::Text(t) => Ok(Value::String(t.to_owned())),
            Literal::Toml(T::String(s)) => Ok(Value::String(s.clone())),
            Literal::Toml(_) => Err(format!(
                "'{literal}' is not a string ('{name}' is a String)"
            )),
        },
    }
}

/// Checks a value against what the model description allows for `var`: a finite number
/// for a Real, within the declared `min` and `max` (FMI 2.0 §2.2.7: a value outside them is
/// an error the FMU may only report later, without the file and line of the value).
pub fn check_value(
    md: &ModelDescription,
    var: &ScalarVariable,
    value: &Value,
) -> Result<(), String> {
    let x = match *value {
        Value::Real(x) => x,
        Value::Integer(n) => f64::from(n),
        Value::Boolean(_) | Value::String(_) => return Ok(()),
    };
    let name = &var.name;
    let shown = Shown(x);
    if !x.is_finite() {
        return Err(format!("{name:?} = {shown} is not a finite number"));
    }
    let (min, max) = md.range_of(var);
    let range = format!(
        "[{}, {}]",
        min.map_or("-inf".to_owned(), |m| Shown(m).to_string()),
        max.map_or("inf".to_owned(), |m| Shown(m).to_string())
    );
    if let Some(m) = min.filter(|&m| x < m) {
        return Err(format!(
            "{name:?} = {shown} is below its declared min = {} (allowed range {range})",
            Shown(m)
        ));
    }
    if let Some(m) = max.filter(|&m| x > m) {
        return Err(format!(
            "{name:?} = {shown} is above its declared max = {} (allowed range {range})",
            Shown(m)
        ));
    }
    Ok(())
}

/// Sets one variable through the accessor family of its type.
pub fn set_value(inst: &mut Instance, vr: u32, value: &Value) -> Result<Status, ImportError> {
    match value {
        Value::Real(x) => inst.set_real(&[vr], &[*x]),
        Value::Integer(n) => inst.set_integer(&[vr], &[*n]),
        Value::Boolean(b) => inst.set_boolean(&[vr], &[*b]),
        Value::String(s) => inst.set_string(&[vr], &[s.as_str()]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MD: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="m" guid="{g}">
  <CoSimulation modelIdentifier="m"/>
  <TypeDefinitions>
    <SimpleType name="Mode"><Enumeration><Item name="off" value="1"/><Item name="on" value="2"/></Enumeration></SimpleType>
  </TypeDefinitions>
  <ModelVariables>
    <ScalarVariable name="a[10]" valueReference="1" causality="parameter" variability="fixed"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="a[2]" valueReference="2" causality="parameter" variability="fixed"><Real start="0" min="-1" max="1"/></ScalarVariable>
    <ScalarVariable name="a[1].x" valueReference="3" causality="parameter" variability="fixed"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="n" valueReference="4" causality="parameter" variability="fixed"><Integer start="0"/></ScalarVariable>
    <ScalarVariable name="b" valueReference="5" causality="parameter" variability="fixed"><Boolean start="false"/></ScalarVariable>
    <ScalarVariable name="mode" valueReference="6" causality="parameter" variability="fixed"><Enumeration declaredType="Mode" start="1"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="7" causality="output"><Real/></ScalarVariable>
    <ScalarVariable name="t" valueReference="8" causality="independent" variability="continuous"><Real/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="7"/></Outputs></ModelStructure>
</fmiModelDescription>"#;

    fn md() -> ModelDescription {
        ModelDescription::parse(MD).unwrap()
    }

    #[test]
    fn arrays_resolve_in_index_order_and_records_are_not_elements() {
        let md = md();
        let names: Vec<&str> = resolve(&md, "a").iter().map(|v| v.name.as_str()).collect();
        assert_eq!(names, ["a[2]", "a[10]"]);
        assert_eq!(resolve(&md, "a[1].x").len(), 1);
        assert!(resolve(&md, "z").is_empty());
        assert!(no_such_variable(&md, "A").contains("similar names: a[10], a[2], a[1].x"));
    }

    #[test]
    fn text_and_toml_convert_by_the_same_rules() {
        let md = md();
        let var = |n: &str| md.variable_by_name(n).unwrap();
        let toml = |s: &str| -> toml::Value {
            toml::from_str::<toml::Table>(&format!("v = {s}")).unwrap()["v"].clone()
        };
        let both = |n: &str, text: &str, t: &str| {
            (
                convert(&md, var(n), Literal::Text(text)),
                convert(&md, var(n), Literal::Toml(&toml(t))),
            )
        };
        assert_eq!(
            both("n", "3.0", "3.0"),
            (Ok(Value::Integer(3)), Ok(Value::Integer(3)))
        );
        assert_eq!(
            both("a[2]", "0.5", "0.5"),
            (Ok(Value::Real(0.5)), Ok(Value::Real(0.5)))
        );
        assert_eq!(
            both("b", "true", "true"),
            (Ok(Value::Boolean(true)), Ok(Value::Boolean(true)))
        );
        assert_eq!(
            both("mode", "on", "\"on\""),
            (Ok(Value::Integer(2)), Ok(Value::Integer(2)))
        );
        assert_eq!(
            both("mode", "2", "2"),
            (Ok(Value::Integer(2)), Ok(Value::Integer(2)))
        );
        let (a, b) = both("n", "2.5", "2.5");
        assert_eq!(a, b);
        assert_eq!(
            a.unwrap_err(),
            "'2.5' is not an integer ('n' is an Integer)"
        );
        let (a, b) = both("n", "2147483648", "2147483648");
        assert_eq!(a, b);
        assert_eq!(
            a.unwrap_err(),
            "'2147483648' is out of range: 'n' is an Integer, from -2147483648 to 2147483647"
        );
        let (a, b) = both("n", "-3e9", "-3e9");
        assert!(a.unwrap_err().contains("out of range"));
        assert!(b.unwrap_err().contains("out of range"));
        let (a, b) = both("mode", "3", "3");
        assert_eq!(a, b);
        assert!(a.unwrap_err().contains("takes one of: off (1), on (2)"));
        // A quoted number is told it is quoted; other text that it is no number.
        assert_eq!(
            convert(&md, var("a[2]"), Literal::Toml(&toml("\"x\""))).unwrap_err(),
            "'x' is not a finite number ('a[2]' is a Real)"
        );
        assert_eq!(
            convert(&md, var("a[2]"), Literal::Toml(&toml("\" 0.5\""))).unwrap_err(),
            "\" 0.5\" is quoted, so it is text, not a number: write it without quotes \
             ('a[2]' is a Real)"
        );
        assert!(convert(&md, var("a[2]"), Literal::Text("nan")).is_err());
    }

    #[test]
    fn integers_accept_integral_numbers_only() {
        assert_eq!(parse_integer("42"), Some(42));
        assert_eq!(parse_integer("-3.0"), Some(-3));
        assert_eq!(parse_integer("2.5"), None);
        assert_eq!(parse_integer("1e10"), None);
        assert_eq!(parse_integer("x"), None);
    }

    #[test]
    fn only_what_fmi_lets_a_master_set_is_settable() {
        let md = md();
        assert!(settable(md.variable_by_name("n").unwrap()).is_ok());
        let e = settable(md.variable_by_name("y").unwrap()).unwrap_err();
        assert!(
            e.contains("'y' is an output and computed by the FMU"),
            "{e}"
        );
        let e = settable(md.variable_by_name("t").unwrap()).unwrap_err();
        assert_eq!(e, "'t' is the independent variable (time)");
        let e = check_value(&md, md.variable_by_name("a[2]").unwrap(), &Value::Real(2.0));
        assert!(e.unwrap_err().contains("above its declared max = 1"));
    }
}
