//! XML text → typed [`ModelDescription`], with line numbers in every error.
//!
//! Two passes: the streaming pass (`scan.rs`) checks well-formedness and the schema's
//! structure and records where each element starts; then `quick_xml::de` fills the raw
//! structs, which are converted here attribute by attribute so an unreadable value is
//! reported with its element, name and line.

use std::str::FromStr;

use super::error::{MdError, MdErrorKind, ParseEnumError};
use super::raw::*;
use super::scan::{Positions, Scan, scan};
use super::*;

/// Conversion context: positions plus the element being converted, for messages.
struct Ctx<'p, 'x> {
    pos: &'p Positions<'x>,
    /// Human label, e.g. `ScalarVariable 'force[1]'`.
    label: String,
    /// Position key and index of the element, for line lookup.
    key: &'static str,
    index: usize,
}

impl Ctx<'_, '_> {
    /// A type or variable holds exactly one type element; `present` says which of
    /// `<Real>`, `<Integer>`, `<Boolean>`, `<String>` and `<Enumeration>` it holds.
    fn one_type_element(&self, present: [bool; 5]) -> Result<(), MdError> {
        let count = present.iter().filter(|&&b| b).count();
        if count == 1 {
            return Ok(());
        }
        Err(self.element_error(format!(
            "needs exactly one of <Real>, <Integer>, <Boolean>, <String>, <Enumeration>, found {count}"
        )))
    }

    fn line(&self) -> Option<usize> {
        self.pos.line(self.key, self.index)
    }

    fn missing(&self, attribute: &str) -> MdError {
        MdError::new(
            self.line(),
            MdErrorKind::MissingAttribute {
                element: self.label.clone(),
                attribute: attribute.into(),
            },
        )
    }

    fn invalid(&self, attribute: &str, value: &str, expected: &str) -> MdError {
        MdError::new(
            self.pos.attr_line(self.key, self.index, attribute),
            MdErrorKind::InvalidAttribute {
                element: self.label.clone(),
                attribute: attribute.into(),
                value: value.into(),
                expected: expected.into(),
            },
        )
    }

    fn element_error(&self, message: impl Into<String>) -> MdError {
        MdError::new(
            self.line(),
            MdErrorKind::InvalidElement {
                element: self.label.clone(),
                message: message.into(),
            },
        )
    }

    fn required(&self, value: Option<String>, attribute: &str) -> Result<String, MdError> {
        value.ok_or_else(|| self.missing(attribute))
    }

    fn bool_or(
        &self,
        value: &Option<String>,
        attribute: &str,
        default: bool,
    ) -> Result<bool, MdError> {
        match value.as_deref().map(str::trim) {
            None => Ok(default),
            Some("true" | "1") => Ok(true),
            Some("false" | "0") => Ok(false),
            Some(other) => Err(self.invalid(attribute, other, "true or false")),
        }
    }

    fn number<T: FromStr>(
        &self,
        value: &Option<String>,
        attribute: &str,
        expected: &str,
    ) -> Result<Option<T>, MdError> {
        match value.as_deref() {
            None => Ok(None),
            Some(text) => text
                .trim()
                .parse()
                .map(Some)
                .map_err(|_| self.invalid(attribute, text, expected)),
        }
    }

    fn real(&self, value: &Option<String>, attribute: &str) -> Result<Option<f64>, MdError> {
        match value.as_deref().map(str::trim) {
            // xs:double spells its special values `INF`, `-INF` and `NaN` and no other way;
            // Rust's parser also takes `inf`, `infinity` and `nan` in any case, which the
            // schema refuses. Apart from those three, only an exponent's `e` is a letter.
            Some("INF") => Ok(Some(f64::INFINITY)),
            Some("-INF") => Ok(Some(f64::NEG_INFINITY)),
            Some(text)
                if text != "NaN"
                    && text
                        .bytes()
                        .any(|b| b.is_ascii_alphabetic() && !matches!(b, b'e' | b'E')) =>
            {
                Err(self.invalid(attribute, text, "a real number"))
            }
            _ => self.number(value, attribute, "a real number"),
        }
    }

    fn int(&self, value: &Option<String>, attribute: &str) -> Result<Option<i32>, MdError> {
        self.number(value, attribute, "a 32-bit integer")
    }

    fn uint(&self, value: &Option<String>, attribute: &str) -> Result<Option<u32>, MdError> {
        self.number(value, attribute, "an unsigned integer")
    }

    fn enumerated<T: FromStr<Err = ParseEnumError>>(
        &self,
        value: &Option<String>,
        attribute: &str,
    ) -> Result<Option<T>, MdError> {
        match value.as_deref() {
            None => Ok(None),
            Some(text) => text
                .parse()
                .map(Some)
                .map_err(|e: ParseEnumError| self.invalid(attribute, text, e.expected)),
        }
    }
}

pub(super) fn parse(xml: &str) -> Result<ModelDescription, MdError> {
    let Scan {
        root,
        positions: pos,
        schema_problems,
    } = scan(xml)?;
    if root != "fmiModelDescription" {
        let line = pos.line(&format!("/{root}"), 0);
        return Err(MdError::new(line, MdErrorKind::WrongRoot(root)));
    }
    let raw: RawModelDescription = quick_xml::de::from_str(xml).map_err(|e| {
        // serde's errors carry no position; an element out of the schema's place or order
        // (a second <DefaultExperiment> is "duplicate field") is what they mean, with a line.
        match schema_problems.first() {
            Some(p) => MdError::new(
                p.line,
                MdErrorKind::InvalidElement {
                    element: p.element.clone(),
                    message: p.message.clone(),
                },
            ),
            None => MdError::new(None, MdErrorKind::Xml(e.to_string())),
        }
    })?;
    convert(raw, &pos, schema_problems)
}

fn convert(
    raw: RawModelDescription,
    pos: &Positions<'_>,
    schema_problems: Vec<Problem>,
) -> Result<ModelDescription, MdError> {
    let root = Ctx {
        pos,
        label: "fmiModelDescription".into(),
        key: "/fmiModelDescription",
        index: 0,
    };
    let fmi_version = root.required(raw.fmi_version, "fmiVersion")?;
    let version = fmi_version.trim();
    if version.starts_with("1.") || version == "1" {
        return Err(MdError::new(
            root.pos.attr_line(root.key, 0, "fmiVersion"),
            MdErrorKind::Fmi1(fmi_version),
        ));
    }
    if version != "2.0" {
        return Err(MdError::new(
            root.pos.attr_line(root.key, 0, "fmiVersion"),
            MdErrorKind::UnsupportedVersion(fmi_version),
        ));
    }
    let model_exchange = raw
        .model_exchange
        .map(|me| convert_me(me, pos))
        .transpose()?;
    let co_simulation = match raw.co_simulation {
        Some(cs) => convert_cs(cs, pos)?,
        None if model_exchange.is_some() => {
            return Err(MdError::new(root.line(), MdErrorKind::ModelExchangeOnly));
        }
        None => return Err(MdError::new(root.line(), MdErrorKind::NoCoSimulation)),
    };
    let variable_naming_convention = match raw.variable_naming_convention.as_deref() {
        None | Some("flat") => VariableNamingConvention::Flat,
        Some("structured") => VariableNamingConvention::Structured,
        Some(other) => {
            return Err(root.invalid("variableNamingConvention", other, "flat or structured"));
        }
    };
    let number_of_event_indicators = root
        .uint(&raw.number_of_event_indicators, "numberOfEventIndicators")?
        .unwrap_or(0);

    let unit_definitions = raw
        .unit_definitions
        .map_or_else(Vec::new, |u| u.units)
        .into_iter()
        .enumerate()
        .map(|(i, u)| convert_unit(u, i, pos))
        .collect::<Result<_, _>>()?;
    let type_definitions = raw
        .type_definitions
        .map_or_else(Vec::new, |t| t.simple_types)
        .into_iter()
        .enumerate()
        .map(|(i, t)| convert_simple_type(t, i, pos))
        .collect::<Result<_, _>>()?;
    let log_categories = raw
        .log_categories
        .map_or_else(Vec::new, |c| c.categories)
        .into_iter()
        .enumerate()
        .map(|(i, c)| {
            let ctx = Ctx {
                pos,
                label: format!("Category #{}", i + 1),
                key: "LogCategories/Category",
                index: i,
            };
            Ok(LogCategory {
                name: ctx.required(c.name, "name")?,
                description: c.description,
            })
        })
        .collect::<Result<_, MdError>>()?;
    let default_experiment = raw
        .default_experiment
        .map(|d| {
            let ctx = Ctx {
                pos,
                label: "DefaultExperiment".into(),
                key: "fmiModelDescription/DefaultExperiment",
                index: 0,
            };
            Ok::<_, MdError>(DefaultExperiment {
                start_time: ctx.real(&d.start_time, "startTime")?,
                stop_time: ctx.real(&d.stop_time, "stopTime")?,
                tolerance: ctx.real(&d.tolerance, "tolerance")?,
                step_size: ctx.real(&d.step_size, "stepSize")?,
            })
        })
        .transpose()?;
    let model_variables = raw
        .model_variables
        .map_or_else(Vec::new, |v| v.variables)
        .into_iter()
        .enumerate()
        .map(|(i, v)| convert_variable(v, i, pos))
        .collect::<Result<_, _>>()?;
    let model_structure = match raw.model_structure {
        Some(ms) => ModelStructure {
            outputs: convert_unknowns(ms.outputs, "Outputs/Unknown", "Outputs", pos)?,
            derivatives: convert_unknowns(
                ms.derivatives,
                "Derivatives/Unknown",
                "Derivatives",
                pos,
            )?,
            initial_unknowns: convert_unknowns(
                ms.initial_unknowns,
                "InitialUnknowns/Unknown",
                "InitialUnknowns",
                pos,
            )?,
        },
        None => return Err(root.element_error("missing required element <ModelStructure>")),
    };
    Ok(ModelDescription {
        fmi_version,
        model_name: root.required(raw.model_name, "modelName")?,
        guid: root.required(raw.guid, "guid")?,
        description: raw.description,
        author: raw.author,
        version: raw.version,
        generation_tool: raw.generation_tool,
        generation_date_and_time: raw.generation_date_and_time,
        variable_naming_convention,
        number_of_event_indicators,
        co_simulation: Some(co_simulation),
        model_exchange,
        unit_definitions,
        type_definitions,
        log_categories,
        default_experiment,
        model_variables,
        model_structure,
        schema_problems,
    })
}

fn convert_cs(cs: RawCoSimulation, pos: &Positions<'_>) -> Result<CoSimulation, MdError> {
    let c = Ctx {
        pos,
        label: "CoSimulation".into(),
        key: "fmiModelDescription/CoSimulation",
        index: 0,
    };
    Ok(CoSimulation {
        model_identifier: c.required(cs.model_identifier, "modelIdentifier")?,
        needs_execution_tool: c.bool_or(&cs.needs_execution_tool, "needsExecutionTool", false)?,
        can_handle_variable_communication_step_size: c.bool_or(
            &cs.can_handle_variable_communication_step_size,
            "canHandleVariableCommunicationStepSize",
            false,
        )?,
        can_interpolate_inputs: c.bool_or(
            &cs.can_interpolate_inputs,
            "canInterpolateInputs",
            false,
        )?,
        max_output_derivative_order: c
            .uint(&cs.max_output_derivative_order, "maxOutputDerivativeOrder")?
            .unwrap_or(0),
        can_run_asynchronuously: c.bool_or(
            &cs.can_run_asynchronuously,
            "canRunAsynchronuously",
            false,
        )?,
        can_be_instantiated_only_once_per_process: c.bool_or(
            &cs.can_be_instantiated_only_once_per_process,
            "canBeInstantiatedOnlyOncePerProcess",
            false,
        )?,
        can_not_use_memory_management_functions: c.bool_or(
            &cs.can_not_use_memory_management_functions,
            "canNotUseMemoryManagementFunctions",
            false,
        )?,
        can_get_and_set_fmu_state: c.bool_or(
            &cs.can_get_and_set_fmu_state,
            "canGetAndSetFMUstate",
            false,
        )?,
        can_serialize_fmu_state: c.bool_or(
            &cs.can_serialize_fmu_state,
            "canSerializeFMUstate",
            false,
        )?,
        provides_directional_derivative: c.bool_or(
            &cs.provides_directional_derivative,
            "providesDirectionalDerivative",
            false,
        )?,
    })
}

fn convert_me(me: RawModelExchange, pos: &Positions<'_>) -> Result<ModelExchangeInfo, MdError> {
    let c = Ctx {
        pos,
        label: "ModelExchange".into(),
        key: "fmiModelDescription/ModelExchange",
        index: 0,
    };
    Ok(ModelExchangeInfo {
        model_identifier: c.required(me.model_identifier, "modelIdentifier")?,
        needs_execution_tool: c.bool_or(&me.needs_execution_tool, "needsExecutionTool", false)?,
        completed_integrator_step_not_needed: c.bool_or(
            &me.completed_integrator_step_not_needed,
            "completedIntegratorStepNotNeeded",
            false,
        )?,
        can_be_instantiated_only_once_per_process: c.bool_or(
            &me.can_be_instantiated_only_once_per_process,
            "canBeInstantiatedOnlyOncePerProcess",
            false,
        )?,
        can_not_use_memory_management_functions: c.bool_or(
            &me.can_not_use_memory_management_functions,
            "canNotUseMemoryManagementFunctions",
            false,
        )?,
        can_get_and_set_fmu_state: c.bool_or(
            &me.can_get_and_set_fmu_state,
            "canGetAndSetFMUstate",
            false,
        )?,
        can_serialize_fmu_state: c.bool_or(
            &me.can_serialize_fmu_state,
            "canSerializeFMUstate",
            false,
        )?,
        provides_directional_derivative: c.bool_or(
            &me.provides_directional_derivative,
            "providesDirectionalDerivative",
            false,
        )?,
    })
}

fn convert_unit(u: RawUnit, i: usize, pos: &Positions<'_>) -> Result<Unit, MdError> {
    let c = Ctx {
        pos,
        label: format!("Unit #{}", i + 1),
        key: "UnitDefinitions/Unit",
        index: i,
    };
    let name = c.required(u.name, "name")?;
    let c = Ctx {
        label: format!("Unit '{name}'"),
        ..c
    };
    let base_unit = u
        .base_unit
        .map(|b| {
            Ok::<_, MdError>(BaseUnit {
                kg: c.int(&b.kg, "kg")?.unwrap_or(0),
                m: c.int(&b.m, "m")?.unwrap_or(0),
                s: c.int(&b.s, "s")?.unwrap_or(0),
                A: c.int(&b.A, "A")?.unwrap_or(0),
                K: c.int(&b.K, "K")?.unwrap_or(0),
                mol: c.int(&b.mol, "mol")?.unwrap_or(0),
                cd: c.int(&b.cd, "cd")?.unwrap_or(0),
                rad: c.int(&b.rad, "rad")?.unwrap_or(0),
                factor: c.real(&b.factor, "factor")?.unwrap_or(1.0),
                offset: c.real(&b.offset, "offset")?.unwrap_or(0.0),
            })
        })
        .transpose()?;
    let display_units = u
        .display_units
        .into_iter()
        .map(|d| {
            Ok(DisplayUnit {
                name: d
                    .name
                    .ok_or_else(|| c.element_error("DisplayUnit without a name"))?,
                factor: c.real(&d.factor, "factor")?.unwrap_or(1.0),
                offset: c.real(&d.offset, "offset")?.unwrap_or(0.0),
            })
        })
        .collect::<Result<_, MdError>>()?;
    Ok(Unit {
        name,
        base_unit,
        display_units,
    })
}

fn convert_simple_type(
    t: RawSimpleType,
    i: usize,
    pos: &Positions<'_>,
) -> Result<SimpleType, MdError> {
    let c = Ctx {
        pos,
        label: format!("SimpleType #{}", i + 1),
        key: "TypeDefinitions/SimpleType",
        index: i,
    };
    let name = c.required(t.name, "name")?;
    let c = Ctx {
        label: format!("SimpleType '{name}'"),
        ..c
    };
    c.one_type_element([
        t.real.is_some(),
        t.integer.is_some(),
        t.boolean.is_some(),
        t.string.is_some(),
        t.enumeration.is_some(),
    ])?;
    let kind = if let Some(r) = t.real {
        SimpleTypeKind::Real {
            quantity: r.quantity,
            unit: r.unit,
            display_unit: r.display_unit,
            relative_quantity: c.bool_or(&r.relative_quantity, "relativeQuantity", false)?,
            min: c.real(&r.min, "min")?,
            max: c.real(&r.max, "max")?,
            nominal: c.real(&r.nominal, "nominal")?,
            unbounded: c.bool_or(&r.unbounded, "unbounded", false)?,
        }
    } else if let Some(n) = t.integer {
        SimpleTypeKind::Integer {
            quantity: n.quantity,
            min: c.int(&n.min, "min")?,
            max: c.int(&n.max, "max")?,
        }
    } else if t.boolean.is_some() {
        SimpleTypeKind::Boolean
    } else if t.string.is_some() {
        SimpleTypeKind::String
    } else if let Some(e) = t.enumeration {
        let items = e
            .items
            .into_iter()
            .map(|item| {
                let name = item
                    .name
                    .ok_or_else(|| c.element_error("Item without a name"))?;
                let value = c
                    .int(&item.value, "value")?
                    .ok_or_else(|| c.element_error(format!("Item '{name}' without a value")))?;
                Ok(Item {
                    name,
                    value,
                    description: item.description,
                })
            })
            .collect::<Result<_, MdError>>()?;
        SimpleTypeKind::Enumeration {
            quantity: e.quantity,
            items,
        }
    } else {
        unreachable!("exactly one type element was counted above")
    };
    Ok(SimpleType {
        name,
        description: t.description,
        kind,
    })
}

fn convert_variable(
    v: RawScalarVariable,
    i: usize,
    pos: &Positions<'_>,
) -> Result<ScalarVariable, MdError> {
    let c = Ctx {
        pos,
        label: format!("ScalarVariable #{}", i + 1),
        key: "ModelVariables/ScalarVariable",
        index: i,
    };
    let name = c.required(v.name, "name")?;
    let c = Ctx {
        label: format!("ScalarVariable '{}'", printable(&name)),
        ..c
    };
    let value_reference = c
        .uint(&v.value_reference, "valueReference")?
        .ok_or_else(|| c.missing("valueReference"))?;
    let causality = c
        .enumerated(&v.causality, "causality")?
        .unwrap_or(Causality::Local);
    let variability = c
        .enumerated(&v.variability, "variability")?
        .unwrap_or(Variability::Continuous);
    let initial = match c.enumerated(&v.initial, "initial")? {
        Some(explicit) => Some(explicit),
        None => default_initial(causality, variability),
    };
    c.one_type_element([
        v.real.is_some(),
        v.integer.is_some(),
        v.boolean.is_some(),
        v.string.is_some(),
        v.enumeration.is_some(),
    ])?;
    let kind = if let Some(r) = v.real {
        VariableKind::Real {
            declared_type: r.declared_type,
            quantity: r.quantity,
            unit: r.unit,
            display_unit: r.display_unit,
            start: c.real(&r.start, "start")?,
            min: c.real(&r.min, "min")?,
            max: c.real(&r.max, "max")?,
            nominal: c.real(&r.nominal, "nominal")?,
            derivative: c.uint(&r.derivative, "derivative")?,
        }
    } else if let Some(n) = v.integer {
        VariableKind::Integer {
            declared_type: n.declared_type,
            start: c.int(&n.start, "start")?,
            min: c.int(&n.min, "min")?,
            max: c.int(&n.max, "max")?,
        }
    } else if let Some(b) = v.boolean {
        VariableKind::Boolean {
            start: match b.start.as_deref().map(str::trim) {
                None => None,
                Some("true" | "1") => Some(true),
                Some("false" | "0") => Some(false),
                Some(other) => return Err(c.invalid("start", other, "true or false")),
            },
        }
    } else if let Some(s) = v.string {
        VariableKind::String { start: s.start }
    } else if let Some(e) = v.enumeration {
        VariableKind::Enumeration {
            declared_type: e.declared_type.ok_or_else(|| c.missing("declaredType"))?,
            start: c.int(&e.start, "start")?,
            min: c.int(&e.min, "min")?,
            max: c.int(&e.max, "max")?,
        }
    } else {
        unreachable!("exactly one type element was counted above")
    };
    Ok(ScalarVariable {
        name,
        value_reference,
        description: v.description,
        causality,
        variability,
        initial,
        kind,
        line: c.line(),
    })
}

fn convert_unknowns(
    list: Option<RawUnknowns>,
    key: &'static str,
    section: &str,
    pos: &Positions<'_>,
) -> Result<Vec<Unknown>, MdError> {
    list.map_or_else(Vec::new, |l| l.unknowns)
        .into_iter()
        .enumerate()
        .map(|(i, u)| {
            let c = Ctx {
                pos,
                label: format!("ModelStructure/{section}/Unknown #{}", i + 1),
                key,
                index: i,
            };
            let index = c
                .number::<usize>(&u.index, "index", "a 1-based variable index")?
                .ok_or_else(|| c.missing("index"))?;
            let dependencies = u
                .dependencies
                .as_deref()
                .map(|text| {
                    text.split_whitespace()
                        .map(|d| {
                            d.parse::<usize>().map_err(|_| {
                                c.invalid("dependencies", text, "1-based variable indices")
                            })
                        })
                        .collect::<Result<Vec<_>, _>>()
                })
                .transpose()?;
            let dependencies_kind = u
                .dependencies_kind
                .as_deref()
                .map(|text| {
                    text.split_whitespace()
                        .map(|d| {
                            d.parse::<DependencyKind>()
                                .map_err(|e| c.invalid("dependenciesKind", d, e.expected))
                        })
                        .collect::<Result<Vec<_>, _>>()
                })
                .transpose()?;
            Ok(Unknown {
                index,
                dependencies,
                dependencies_kind,
                line: c.line(),
            })
        })
        .collect()
}

impl Causality {
    /// The model description's spelling, e.g. `calculatedParameter`.
    pub fn as_str(self) -> &'static str {
        match self {
            Causality::Parameter => "parameter",
            Causality::CalculatedParameter => "calculatedParameter",
            Causality::Input => "input",
            Causality::Output => "output",
            Causality::Local => "local",
            Causality::Independent => "independent",
        }
    }
}

impl Variability {
    /// The model description's spelling, e.g. `tunable`.
    pub fn as_str(self) -> &'static str {
        match self {
            Variability::Constant => "constant",
            Variability::Fixed => "fixed",
            Variability::Tunable => "tunable",
            Variability::Discrete => "discrete",
            Variability::Continuous => "continuous",
        }
    }
}

impl Initial {
    /// The model description's spelling, e.g. `calculated`.
    pub fn as_str(self) -> &'static str {
        match self {
            Initial::Exact => "exact",
            Initial::Approx => "approx",
            Initial::Calculated => "calculated",
        }
    }
}

impl FromStr for Causality {
    type Err = ParseEnumError;
    fn from_str(s: &str) -> Result<Self, ParseEnumError> {
        Ok(match s {
            "parameter" => Causality::Parameter,
            "calculatedParameter" => Causality::CalculatedParameter,
            "input" => Causality::Input,
            "output" => Causality::Output,
            "local" => Causality::Local,
            "independent" => Causality::Independent,
            _ => {
                return Err(ParseEnumError {
                    what: "causality",
                    value: s.into(),
                    expected: "parameter, calculatedParameter, input, output, local, independent",
                });
            }
        })
    }
}

impl FromStr for Variability {
    type Err = ParseEnumError;
    fn from_str(s: &str) -> Result<Self, ParseEnumError> {
        Ok(match s {
            "constant" => Variability::Constant,
            "fixed" => Variability::Fixed,
            "tunable" => Variability::Tunable,
            "discrete" => Variability::Discrete,
            "continuous" => Variability::Continuous,
            _ => {
                return Err(ParseEnumError {
                    what: "variability",
                    value: s.into(),
                    expected: "constant, fixed, tunable, discrete, continuous",
                });
            }
        })
    }
}

impl FromStr for Initial {
    type Err = ParseEnumError;
    fn from_str(s: &str) -> Result<Self, ParseEnumError> {
        Ok(match s {
            "exact" => Initial::Exact,
            "approx" => Initial::Approx,
            "calculated" => Initial::Calculated,
            _ => {
                return Err(ParseEnumError {
                    what: "initial",
                    value: s.into(),
                    expected: "exact, approx, calculated",
                });
            }
        })
    }
}

impl FromStr for DependencyKind {
    type Err = ParseEnumError;
    fn from_str(s: &str) -> Result<Self, ParseEnumError> {
        Ok(match s {
            "dependent" => DependencyKind::Dependent,
            "constant" => DependencyKind::Constant,
            "fixed" => DependencyKind::Fixed,
            "tunable" => DependencyKind::Tunable,
            "discrete" => DependencyKind::Discrete,
            _ => {
                return Err(ParseEnumError {
                    what: "dependenciesKind",
                    value: s.into(),
                    expected: "dependent, constant, fixed, tunable, discrete",
                });
            }
        })
    }
}
