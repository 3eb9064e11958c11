//! modelDescription.xml: typed structs, parsing and validation.
//!
//! [`ModelDescription::parse`] turns the XML into typed structs, applying the FMI 2.0
//! defaults (causality `local`, variability `continuous`, `initial` per the standard's
//! table) and failing with an [`MdError`] that names the line and element when the XML is
//! malformed or an attribute cannot be read. [`ModelDescription::validate`] then checks
//! the semantic rules of the standard and returns every [`Problem`] at once, so a broken
//! description can be fixed in one pass.
//!
//! [`codegen::codegen_rust`] emits the Rust constants an FMU crate's build script
//! `include!`s, so the XML stays the single source of truth for value references.
#![forbid(unsafe_code)]

pub mod codegen;
mod datetime;
mod error;
mod names;
mod parse;
mod raw;
mod scan;
mod schema;
mod shown;
mod validate;

use std::path::Path;

/// FMI base type of a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VarType {
    Real,
    Integer,
    Boolean,
    String,
    Enumeration,
}

/// Causality as declared in the model description.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Causality {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
    Local,
    Independent,
}

/// Variability as declared in the model description.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variability {
    Constant,
    Fixed,
    Tunable,
    Discrete,
    Continuous,
}
pub use error::{MdError, MdErrorKind, ParseEnumError, Problem};
pub use shown::{Shown, time_spacing};

/// A parsed FMI 2.0 model description.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelDescription {
    /// `fmiVersion`; always `"2.0"` for a description `parse` accepts.
    pub fmi_version: String,
    /// `modelName` attribute.
    pub model_name: String,
    /// `guid` attribute.
    pub guid: String,
    /// `description` attribute.
    pub description: Option<String>,
    /// `author` attribute.
    pub author: Option<String>,
    /// `version` attribute.
    pub version: Option<String>,
    /// `generationTool` attribute.
    pub generation_tool: Option<String>,
    /// Raw `generationDateAndTime` text; `validate` checks that it is an `xs:dateTime`.
    pub generation_date_and_time: Option<String>,
    /// `variableNamingConvention` attribute.
    pub variable_naming_convention: VariableNamingConvention,
    /// `numberOfEventIndicators` (0 when absent).
    pub number_of_event_indicators: u32,
    /// The `<CoSimulation>` element. `parse` rejects descriptions without it (this
    /// project only runs co-simulation), so it is `Some` for every parsed description;
    /// it stays an `Option` because the schema makes it optional.
    pub co_simulation: Option<CoSimulation>,
    /// The `<ModelExchange>` element's content.
    pub model_exchange: Option<ModelExchangeInfo>,
    /// The `<UnitDefinitions>` element's content.
    pub unit_definitions: Vec<Unit>,
    /// The `<TypeDefinitions>` element's content.
    pub type_definitions: Vec<SimpleType>,
    /// The `<LogCategories>` element's content.
    pub log_categories: Vec<LogCategory>,
    /// The `<DefaultExperiment>` element's content.
    pub default_experiment: Option<DefaultExperiment>,
    /// The `<ModelVariables>` element's content.
    pub model_variables: Vec<ScalarVariable>,
    /// The `<ModelStructure>` element's content.
    pub model_structure: ModelStructure,
    /// What the FMI 2.0 schema does not allow (elements out of place, order or count,
    /// missing children, undefined attributes, text): found by the parse, which reads what
    /// it knows in any order and skips the rest, and reported by `validate`.
    schema_problems: Vec<Problem>,
}

/// `variableNamingConvention`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VariableNamingConvention {
    /// Any string is a name (the default).
    #[default]
    Flat,
    /// Names such as `a.b[3]` denote hierarchy and arrays.
    Structured,
}

/// The `<CoSimulation>` capability flags (all default to false, as in the standard).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct CoSimulation {
    /// Base name of the shared library in `binaries/<platform>/`.
    pub model_identifier: String,
    /// `needsExecutionTool` attribute.
    pub needs_execution_tool: bool,
    /// `canHandleVariableCommunicationStepSize` attribute.
    pub can_handle_variable_communication_step_size: bool,
    /// `canInterpolateInputs` attribute.
    pub can_interpolate_inputs: bool,
    /// `maxOutputDerivativeOrder` (0 when absent).
    pub max_output_derivative_order: u32,
    /// Spelled as the standard misspells it.
    pub can_run_asynchronuously: bool,
    /// `canBeInstantiatedOnlyOncePerProcess` attribute.
    pub can_be_instantiated_only_once_per_process: bool,
    /// `canNotUseMemoryManagementFunctions` attribute.
    pub can_not_use_memory_management_functions: bool,
    /// `canGetAndSetFMUstate` attribute.
    pub can_get_and_set_fmu_state: bool,
    /// `canSerializeFMUstate` attribute.
    pub can_serialize_fmu_state: bool,
    /// `providesDirectionalDerivative` attribute.
    pub provides_directional_derivative: bool,
}

/// The `<ModelExchange>` element, kept so tools can tell what else the FMU offers.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ModelExchangeInfo {
    /// `modelIdentifier` attribute.
    pub model_identifier: String,
    /// `needsExecutionTool` attribute.
    pub needs_execution_tool: bool,
    /// `completedIntegratorStepNotNeeded` attribute.
    pub completed_integrator_step_not_needed: bool,
    /// `canBeInstantiatedOnlyOncePerProcess` attribute.
    pub can_be_instantiated_only_once_per_process: bool,
    /// `canNotUseMemoryManagementFunctions` attribute.
    pub can_not_use_memory_management_functions: bool,
    /// `canGetAndSetFMUstate` attribute.
    pub can_get_and_set_fmu_state: bool,
    /// `canSerializeFMUstate` attribute.
    pub can_serialize_fmu_state: bool,
    /// `providesDirectionalDerivative` attribute.
    pub provides_directional_derivative: bool,
}

/// A `<Unit>` of `<UnitDefinitions>`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Unit {
    /// `name` attribute.
    pub name: String,
    /// The `<BaseUnit>` child.
    pub base_unit: Option<BaseUnit>,
    /// The `<DisplayUnit>` children.
    pub display_units: Vec<DisplayUnit>,
}

/// SI base-unit exponents with factor and offset: value_SI = factor * value + offset.
#[derive(Debug, Clone, PartialEq, Default)]
#[allow(non_snake_case)] // The SI symbols are case-significant (`K` vs `kg`); keep the standard's spelling.
pub struct BaseUnit {
    /// Exponent of kilogram.
    pub kg: i32,
    /// Exponent of metre.
    pub m: i32,
    /// Exponent of second.
    pub s: i32,
    /// Exponent of ampere.
    pub A: i32,
    /// Exponent of kelvin.
    pub K: i32,
    /// Exponent of mole.
    pub mol: i32,
    /// Exponent of candela.
    pub cd: i32,
    /// Exponent of radian.
    pub rad: i32,
    /// Defaults to 1.
    pub factor: f64,
    /// Defaults to 0.
    pub offset: f64,
}

/// A `<DisplayUnit>`: value_unit = factor * value_display + offset.
#[derive(Debug, Clone, PartialEq)]
pub struct DisplayUnit {
    /// `name` attribute.
    pub name: String,
    /// Defaults to 1.
    pub factor: f64,
    /// Defaults to 0.
    pub offset: f64,
}

/// A `<SimpleType>` of `<TypeDefinitions>`.
#[derive(Debug, Clone, PartialEq)]
pub struct SimpleType {
    /// `name` attribute.
    pub name: String,
    /// `description` attribute.
    pub description: Option<String>,
    /// The base type and its attributes.
    pub kind: SimpleTypeKind,
}

/// The base type of a [`SimpleType`] with its attributes.
#[derive(Debug, Clone, PartialEq)]
pub enum SimpleTypeKind {
    /// `<Real>`.
    Real {
        /// `quantity` attribute.
        quantity: Option<String>,
        /// `unit` attribute.
        unit: Option<String>,
        /// `displayUnit` attribute.
        display_unit: Option<String>,
        /// `relativeQuantity` attribute.
        relative_quantity: bool,
        /// `min` attribute.
        min: Option<f64>,
        /// `max` attribute.
        max: Option<f64>,
        /// `nominal` attribute.
        nominal: Option<f64>,
        /// `unbounded` attribute.
        unbounded: bool,
    },
    /// `<Integer>`.
    Integer {
        /// `quantity` attribute.
        quantity: Option<String>,
        /// `min` attribute.
        min: Option<i32>,
        /// `max` attribute.
        max: Option<i32>,
    },
    /// `<Boolean>`.
    Boolean,
    /// `<String>`.
    String,
    /// `<Enumeration>`.
    Enumeration {
        /// `quantity` attribute.
        quantity: Option<String>,
        /// The `<Item>` children.
        items: Vec<Item>,
    },
}

/// One `<Item>` of an enumeration type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Item {
    /// `name` attribute.
    pub name: String,
    /// `value` attribute.
    pub value: i32,
    /// `description` attribute.
    pub description: Option<String>,
}

/// A `<Category>` of `<LogCategories>`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogCategory {
    /// `name` attribute.
    pub name: String,
    /// `description` attribute.
    pub description: Option<String>,
}

/// `<DefaultExperiment>`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DefaultExperiment {
    /// `startTime` attribute.
    pub start_time: Option<f64>,
    /// `stopTime` attribute.
    pub stop_time: Option<f64>,
    /// `tolerance` attribute.
    pub tolerance: Option<f64>,
    /// `stepSize` attribute.
    pub step_size: Option<f64>,
}

/// `initial` of a scalar variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Initial {
    /// Initialised with the start value.
    Exact,
    /// Iteration variable started at the start value.
    Approx,
    /// Computed from other variables; no start value.
    Calculated,
}

/// A `<ScalarVariable>` with the standard's defaults applied.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalarVariable {
    /// `name` attribute.
    pub name: String,
    /// `valueReference` attribute.
    pub value_reference: u32,
    /// `description` attribute.
    pub description: Option<String>,
    /// Defaults to `local`.
    pub causality: Causality,
    /// Defaults to `continuous`.
    pub variability: Variability,
    /// As written, or the default of the standard's causality/variability table; `None`
    /// where the table allows no `initial` (inputs, the independent variable) or the
    /// combination itself is illegal.
    pub initial: Option<Initial>,
    /// The base type and its attributes.
    pub kind: VariableKind,
    /// 1-based line of the element in the parsed file, for messages; `None` when built by hand.
    pub line: Option<usize>,
}

/// The type element of a scalar variable.
#[derive(Debug, Clone, PartialEq)]
pub enum VariableKind {
    /// `<Real>`.
    Real {
        /// `declaredType` attribute.
        declared_type: Option<String>,
        /// `quantity` attribute.
        quantity: Option<String>,
        /// `unit` attribute.
        unit: Option<String>,
        /// `displayUnit` attribute.
        display_unit: Option<String>,
        /// `start` attribute.
        start: Option<f64>,
        /// `min` attribute.
        min: Option<f64>,
        /// `max` attribute.
        max: Option<f64>,
        /// `nominal` attribute.
        nominal: Option<f64>,
        /// 1-based index of the state whose derivative this is.
        derivative: Option<u32>,
    },
    /// `<Integer>`.
    Integer {
        /// `declaredType` attribute.
        declared_type: Option<String>,
        /// `start` attribute.
        start: Option<i32>,
        /// `min` attribute.
        min: Option<i32>,
        /// `max` attribute.
        max: Option<i32>,
    },
    /// `<Boolean>`.
    Boolean {
        /// `start` attribute.
        start: Option<bool>,
    },
    /// `<String>`.
    String {
        /// `start` attribute.
        start: Option<String>,
    },
    /// `<Enumeration>`.
    Enumeration {
        /// `declaredType` attribute.
        declared_type: String,
        /// `start` attribute.
        start: Option<i32>,
        /// `min` attribute.
        min: Option<i32>,
        /// `max` attribute.
        max: Option<i32>,
    },
}

impl ScalarVariable {
    /// The FMI base type, which selects the get/set function family.
    pub fn var_type(&self) -> VarType {
        match self.kind {
            VariableKind::Real { .. } => VarType::Real,
            VariableKind::Integer { .. } => VarType::Integer,
            VariableKind::Boolean { .. } => VarType::Boolean,
            VariableKind::String { .. } => VarType::String,
            VariableKind::Enumeration { .. } => VarType::Enumeration,
        }
    }

    /// Whether the variable has a start value.
    pub fn has_start(&self) -> bool {
        match &self.kind {
            VariableKind::Real { start, .. } => start.is_some(),
            VariableKind::Integer { start, .. } | VariableKind::Enumeration { start, .. } => {
                start.is_some()
            }
            VariableKind::Boolean { start } => start.is_some(),
            VariableKind::String { start } => start.is_some(),
        }
    }

    /// The start value as a Real (booleans as 0/1); `None` for strings and absent starts.
    pub fn start_as_f64(&self) -> Option<f64> {
        match &self.kind {
            VariableKind::Real { start, .. } => *start,
            VariableKind::Integer { start, .. } | VariableKind::Enumeration { start, .. } => {
                start.map(f64::from)
            }
            VariableKind::Boolean { start } => start.map(|b| if b { 1.0 } else { 0.0 }),
            VariableKind::String { .. } => None,
        }
    }
}

/// `<ModelStructure>`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ModelStructure {
    /// The `<Outputs>` list.
    pub outputs: Vec<Unknown>,
    /// The `<Derivatives>` list.
    pub derivatives: Vec<Unknown>,
    /// The `<InitialUnknowns>` list.
    pub initial_unknowns: Vec<Unknown>,
}

/// An `<Unknown>` of the model structure.
#[derive(Debug, Clone, PartialEq)]
pub struct Unknown {
    /// 1-based index into `model_variables`.
    pub index: usize,
    /// 1-based indices it depends on; `None` when the attribute is absent (depends on all).
    pub dependencies: Option<Vec<usize>>,
    /// `dependenciesKind` attribute.
    pub dependencies_kind: Option<Vec<DependencyKind>>,
    /// 1-based line of the element in the parsed file; `None` when built by hand.
    pub line: Option<usize>,
}

/// One entry of `dependenciesKind`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DependencyKind {
    /// `dependent`: depends on the listed variable in any way.
    Dependent,
    /// `constant`: a constant factor.
    Constant,
    /// `fixed`: depends on fixed parameters only.
    Fixed,
    /// `tunable`: depends on tunable parameters.
    Tunable,
    /// `discrete`: changes only at events.
    Discrete,
}

/// `text` with its control characters and bidirectional formatting characters written as
/// `\u{..}` and its backslashes doubled, for names, descriptions and labels shown to a user:
/// a name from a foreign file must not move a terminal's cursor, clear it or reorder the
/// text after it, and a name that holds the six characters `\u{1b}` must still read
/// differently from one that holds ESC.
pub fn printable(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(|c| hidden(c) || c == '\\') {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if c == '\\' {
            out.push_str("\\\\");
        } else if hidden(c) {
            out.extend(c.escape_unicode());
        } else {
            out.push(c);
        }
    }
    std::borrow::Cow::Owned(out)
}

/// Characters [`printable`] escapes: control characters, and the bidirectional marks,
/// embeddings, overrides and isolates, which would reorder what a terminal shows after them.
fn hidden(c: char) -> bool {
    c.is_control()
        || matches!(c, '\u{200e}' | '\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

impl ModelDescription {
    /// Parses a model description from its XML text. Fails on malformed XML, unreadable
    /// attribute values, FMI versions other than 2.0 and descriptions without
    /// `<CoSimulation>`; semantic rules are left to [`validate`](Self::validate).
    pub fn parse(xml: &str) -> Result<ModelDescription, MdError> {
        parse::parse(xml)
    }

    /// Reads and parses a file; errors carry the file name.
    pub fn from_file(path: impl AsRef<Path>) -> Result<ModelDescription, MdError> {
        let path = path.as_ref();
        let xml = std::fs::read_to_string(path).map_err(|e| MdError {
            file: Some(path.to_path_buf()),
            line: None,
            kind: Box::new(MdErrorKind::Io(e.to_string())),
        })?;
        parse::parse(&xml).map_err(|e| e.in_file(path))
    }

    /// Checks the FMI 2.0 rules and returns every problem found (empty when valid).
    pub fn validate(&self) -> Vec<Problem> {
        validate::validate(self)
    }

    /// The bounds a value of `v` must respect: its own `min`/`max`, else those of its
    /// declared type; for an Enumeration without bounds, the smallest and largest item, since
    /// no other value means anything. `None` where unbounded (and for Boolean and String).
    pub fn range_of(&self, v: &ScalarVariable) -> (Option<f64>, Option<f64>) {
        let declared = |name: Option<&str>| name.and_then(|n| self.simple_type(n)).map(|t| &t.kind);
        match &v.kind {
            VariableKind::Real {
                declared_type,
                min,
                max,
                ..
            } => {
                let (tmin, tmax) = match declared(declared_type.as_deref()) {
                    Some(SimpleTypeKind::Real { min, max, .. }) => (*min, *max),
                    _ => (None, None),
                };
                (min.or(tmin), max.or(tmax))
            }
            VariableKind::Integer {
                declared_type,
                min,
                max,
                ..
            } => {
                let (tmin, tmax) = match declared(declared_type.as_deref()) {
                    Some(SimpleTypeKind::Integer { min, max, .. }) => (*min, *max),
                    _ => (None, None),
                };
                (min.or(tmin).map(f64::from), max.or(tmax).map(f64::from))
            }
            VariableKind::Enumeration {
                declared_type,
                min,
                max,
                ..
            } => {
                let items = match declared(Some(declared_type)) {
                    Some(SimpleTypeKind::Enumeration { items, .. }) => items.as_slice(),
                    _ => &[],
                };
                let lo = items.iter().map(|i| i.value).min();
                let hi = items.iter().map(|i| i.value).max();
                (min.or(lo).map(f64::from), max.or(hi).map(f64::from))
            }
            VariableKind::Boolean { .. } | VariableKind::String { .. } => (None, None),
        }
    }

    /// The variable with this exact name.
    pub fn variable_by_name(&self, name: &str) -> Option<&ScalarVariable> {
        self.model_variables.iter().find(|v| v.name == name)
    }

    /// The first variable with this value reference in the accessor family of `var_type`.
    /// Integer and Enumeration share `fmi2Get/SetInteger`, so either finds both.
    pub fn variable_by_vr(&self, var_type: VarType, vr: u32) -> Option<&ScalarVariable> {
        let family = accessor_family(var_type);
        self.model_variables
            .iter()
            .find(|v| v.value_reference == vr && accessor_family(v.var_type()) == family)
    }

    /// The CoSimulation element's `modelIdentifier`, if any.
    pub fn model_identifier(&self) -> Option<&str> {
        self.co_simulation
            .as_ref()
            .map(|cs| cs.model_identifier.as_str())
    }

    /// Looks up a unit definition by name.
    pub fn unit(&self, name: &str) -> Option<&Unit> {
        self.unit_definitions.iter().find(|u| u.name == name)
    }

    /// The unit of a Real variable: its own `unit`, else its declared type's. `None` for
    /// other types and for Reals without one.
    pub fn unit_of<'a>(&'a self, v: &'a ScalarVariable) -> Option<&'a str> {
        let VariableKind::Real {
            declared_type,
            unit,
            ..
        } = &v.kind
        else {
            return None;
        };
        unit.as_deref().or_else(
            || match &self.simple_type(declared_type.as_deref()?)?.kind {
                SimpleTypeKind::Real { unit, .. } => unit.as_deref(),
                _ => None,
            },
        )
    }

    /// Looks up a type definition by name.
    pub fn simple_type(&self, name: &str) -> Option<&SimpleType> {
        self.type_definitions.iter().find(|t| t.name == name)
    }

    /// The value of the item named `item` in the enumeration type of the variable
    /// `variable`: masters and tests set enumerations by item name, so renumbering an item
    /// in the XML needs no edit elsewhere. `None` if either is unknown.
    pub fn enumeration_item(&self, variable: &str, item: &str) -> Option<i32> {
        let VariableKind::Enumeration { declared_type, .. } =
            &self.variable_by_name(variable)?.kind
        else {
            return None;
        };
        let SimpleTypeKind::Enumeration { items, .. } = &self.simple_type(declared_type)?.kind
        else {
            return None;
        };
        items.iter().find(|i| i.name == item).map(|i| i.value)
    }
}

/// Integer and Enumeration values travel through the same C functions, so they share
/// one value-reference space.
fn accessor_family(t: VarType) -> VarType {
    match t {
        VarType::Enumeration => VarType::Integer,
        other => other,
    }
}

/// The default `initial` of the FMI 2.0 causality/variability table (cases A, B, C);
/// `None` for cases D and E and for illegal combinations.
pub fn default_initial(causality: Causality, variability: Variability) -> Option<Initial> {
    match allowed_initials(causality, variability) {
        Some(InitialRule { default, .. }) => default,
        None => None,
    }
}

/// Which `initial` values the standard's table allows for a combination.
#[derive(Debug, Clone, Copy)]
pub(crate) struct InitialRule {
    pub(crate) allowed: &'static [Initial],
    pub(crate) default: Option<Initial>,
}

/// The FMI 2.0 table; `None` if the combination itself is illegal.
pub(crate) fn allowed_initials(c: Causality, v: Variability) -> Option<InitialRule> {
    use Causality as C;
    use Variability as V;
    const A: InitialRule = InitialRule {
        allowed: &[Initial::Exact],
        default: Some(Initial::Exact),
    };
    const B: InitialRule = InitialRule {
        allowed: &[Initial::Approx, Initial::Calculated],
        default: Some(Initial::Calculated),
    };
    const C_: InitialRule = InitialRule {
        allowed: &[Initial::Exact, Initial::Approx, Initial::Calculated],
        default: Some(Initial::Calculated),
    };
    const NONE: InitialRule = InitialRule {
        allowed: &[],
        default: None,
    };
    match (v, c) {
        (V::Constant, C::Output | C::Local) => Some(A),
        (V::Fixed | V::Tunable, C::Parameter) => Some(A),
        (V::Fixed | V::Tunable, C::CalculatedParameter | C::Local) => Some(B),
        (V::Discrete | V::Continuous, C::Input) => Some(NONE),
        (V::Discrete | V::Continuous, C::Output | C::Local) => Some(C_),
        (V::Continuous, C::Independent) => Some(NONE),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::printable;

    /// Plain text passes unchanged; control and bidirectional formatting characters are
    /// written as escapes, backslashes doubled, so that no two names read the same.
    #[test]
    fn printable_escapes_what_would_drive_or_reorder_a_terminal() {
        for plain in ["force[1]", "Längen", "x 𝛼", "der(x)"] {
            assert_eq!(printable(plain), plain);
        }
        for (text, shown) in [
            ("a\u{1b}[31mb", "a\\u{1b}[31mb"),
            ("a\u{9b}b", "a\\u{9b}b"),
            ("a\u{202e}b", "a\\u{202e}b"),
            ("a\u{2066}b\u{2069}", "a\\u{2066}b\\u{2069}"),
            ("a\u{200f}b", "a\\u{200f}b"),
            ("a\\u{1b}", "a\\\\u{1b}"),
            ("\\", "\\\\"),
        ] {
            assert_eq!(printable(text), shown, "{text:?}");
        }
    }
}
