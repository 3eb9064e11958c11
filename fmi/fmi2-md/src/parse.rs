//! XML text → typed [`ModelDescription`], with line numbers in every error.
//!
//! Two passes: a streaming pass with quick-xml's `Reader` checks well-formedness (its
//! errors carry a byte offset, serde's do not) and records where each element starts;
//! then `quick_xml::de` fills the raw structs, which are converted here attribute by
//! attribute so an unreadable value is reported with its element, name and line.

use std::collections::HashMap;
use std::str::FromStr;

use quick_xml::Reader;
use quick_xml::events::Event;
use quick_xml::events::attributes::AttrError;

use super::error::{MdError, MdErrorKind, ParseEnumError};
use super::raw::*;
use super::schema::{self, Content, Place};
use super::*;

/// Byte offsets of element starts, keyed by `parent/name`, in document order.
struct Positions<'a> {
    xml: &'a str,
    starts: HashMap<String, Vec<usize>>,
    /// Byte offset of every `\n`, ascending, so a line lookup is a binary search: every
    /// variable records its line, and counting from the start each time made parsing
    /// quadratic in the file size.
    newlines: Vec<usize>,
}

impl<'a> Positions<'a> {
    fn new(xml: &'a str) -> Self {
        Self {
            xml,
            starts: HashMap::new(),
            newlines: xml
                .bytes()
                .enumerate()
                .filter_map(|(i, b)| (b == b'\n').then_some(i))
                .collect(),
        }
    }

    /// 1-based line of a byte offset.
    fn line_at(&self, offset: usize) -> usize {
        let end = offset.min(self.xml.len());
        self.newlines.partition_point(|&n| n < end) + 1
    }

    /// Offset of the `i`-th element with this `parent/name` key.
    fn offset(&self, key: &str, i: usize) -> Option<usize> {
        self.starts.get(key).and_then(|v| v.get(i)).copied()
    }

    /// Line of the `i`-th element with this key.
    fn line(&self, key: &str, i: usize) -> Option<usize> {
        self.offset(key, i).map(|o| self.line_at(o))
    }

    /// serde's "duplicate field `X`" (a second `<CoSimulation>`, which the schema's
    /// structure allows) as an error at the second `<X>`'s line.
    fn second(&self, serde_message: &str) -> Option<MdError> {
        let name = serde_message
            .strip_prefix("duplicate field `")?
            .strip_suffix('`')?;
        let (key, at) = self
            .starts
            .iter()
            .filter(|(key, _)| key.rsplit('/').next() == Some(name))
            .filter_map(|(key, at)| Some((key, *at.get(1)?)))
            .min_by_key(|&(_, at)| at)?;
        let parent = key.rsplit_once('/').map_or("", |(parent, _)| parent);
        Some(MdError::new(
            Some(self.line_at(at)),
            MdErrorKind::InvalidElement {
                element: parent.to_owned(),
                message: format!("a second <{name}>; there may be only one"),
            },
        ))
    }

    /// Line of `attribute` in the start tag between these offsets, else the tag's first.
    fn attribute_line(&self, start: usize, end: usize, attribute: &str) -> usize {
        let tag = self.xml.get(start..end).unwrap_or("");
        let found = [' ', '\n', '\t', '\r']
            .iter()
            .filter_map(|c| tag.find(&format!("{c}{attribute}=")))
            .min();
        self.line_at(start + found.map_or(0, |f| f + 1))
    }

    /// Line of `attribute` at or after the `i`-th element with this key, falling back to
    /// the element's own line (attributes may sit on continuation lines or in a child).
    fn attr_line(&self, key: &str, i: usize, attribute: &str) -> Option<usize> {
        let start = self.offset(key, i)?;
        let rest = &self.xml[start..];
        let found = [
            format!(" {attribute}="),
            format!("\n{attribute}="),
            format!("\t{attribute}="),
        ]
        .iter()
        .filter_map(|pat| rest.find(pat.as_str()))
        .min();
        Some(self.line_at(start + found.map_or(0, |f| f + 1)))
    }
}

/// At most this many schema problems are reported one by one; a generated file with
/// thousands would otherwise bury the first under the rest.
const SCHEMA_REPORTED: usize = 100;

/// What the streaming pass finds: the root's name, where elements start, and what the
/// schema does not allow (see `schema.rs`).
struct Scan<'a> {
    root: String,
    positions: Positions<'a>,
    schema_problems: Vec<Problem>,
}

/// The schema problems found so far: the first [`SCHEMA_REPORTED`], then a count.
#[derive(Default)]
struct Reports {
    listed: Vec<Problem>,
    unlisted: usize,
}

impl Reports {
    fn push(&mut self, line: usize, element: &str, message: String) {
        if self.listed.len() < SCHEMA_REPORTED {
            self.listed.push(Problem {
                line: Some(line),
                element: element.to_owned(),
                message,
            });
        } else {
            self.unlisted += 1;
        }
    }

    fn into_problems(mut self) -> Vec<Problem> {
        if self.unlisted > 0 {
            self.listed.push(Problem {
                line: None,
                element: "fmiModelDescription".into(),
                message: format!("{} more problems with the schema", self.unlisted),
            });
        }
        self.listed
    }
}

/// Text other than whitespace at `offset`, inside the innermost open element: a problem
/// where the schema allows elements only (every FMI 2.0 element but a `<Tool>`'s content),
/// reported once per element.
fn text_inside(
    stack: &mut [(String, usize, Place)],
    reports: &mut Reports,
    positions: &Positions<'_>,
    offset: usize,
) {
    if let Some((name, _, place)) = stack.last_mut() {
        if let Some(message) = place.text() {
            reports.push(positions.line_at(offset), name, message);
        }
    }
}

/// Checks well-formedness, records element positions and checks the schema (`schema.rs`).
fn scan(xml: &str) -> Result<Scan<'_>, MdError> {
    let mut reader = Reader::from_str(xml);
    let mut positions = Positions::new(xml);
    let mut stack: Vec<(String, usize, Place)> = Vec::new();
    let mut document = Place::new(Content::Document);
    let mut root: Option<String> = None;
    let mut reports = Reports::default();
    loop {
        let before = usize::try_from(reader.buffer_position()).unwrap_or(usize::MAX);
        let event = match reader.read_event() {
            Ok(e) => e,
            Err(e) => {
                let at = usize::try_from(reader.error_position()).unwrap_or(usize::MAX);
                let line = positions.line_at(at);
                return Err(MdError::new(Some(line), MdErrorKind::Xml(e.to_string())));
            }
        };
        match event {
            Event::Start(ref s) | Event::Empty(ref s) => {
                let name = s.name().as_ref().to_owned();
                if stack.is_empty() && root.is_some() {
                    let line = positions.line_at(before);
                    return Err(MdError::new(
                        Some(line),
                        MdErrorKind::Xml(format!("second root element <{name}>")),
                    ));
                }
                let (parent, place) = match stack.last_mut() {
                    Some((p, _, place)) => (p.as_str(), place),
                    None => ("", &mut document),
                };
                let content = place.admit(&name).unwrap_or_else(|message| {
                    reports.push(positions.line_at(before), parent, message);
                    Content::Refused
                });
                let defined = match content {
                    Content::Refused => None,
                    _ => schema::attributes(place.content(), &name),
                };
                let after = usize::try_from(reader.buffer_position()).unwrap_or(usize::MAX);
                for attribute in s.attributes() {
                    let attribute = match attribute {
                        Ok(a) => a,
                        // A malformed attribute makes the file malformed; the error names the
                        // line of the faulty one (serde would say only "position 25" within
                        // its tag).
                        Err(e) => {
                            let at = match e {
                                AttrError::ExpectedEq(p)
                                | AttrError::ExpectedValue(p)
                                | AttrError::UnquotedValue(p)
                                | AttrError::ExpectedQuote(p, _)
                                | AttrError::Duplicated(p, _) => p,
                            };
                            // Positions count from the tag's name, one byte after its `<`.
                            let line = positions.line_at(before.saturating_add(1 + at));
                            return Err(MdError::new(
                                Some(line),
                                MdErrorKind::Xml(format!("<{name}>: {e}")),
                            ));
                        }
                    };
                    let key = attribute.key.into_inner();
                    let undefined = defined.is_some_and(|groups| {
                        !(groups.iter().any(|g| g.contains(&key))
                            || key.starts_with("xmlns")
                            || key.starts_with("xsi:"))
                    });
                    if undefined {
                        reports.push(
                            positions.attribute_line(before, after, key),
                            &name,
                            format!(
                                "attribute '{key}' is not defined for <{name}> by the FMI 2.0 schema"
                            ),
                        );
                    }
                }
                positions
                    .starts
                    .entry(format!("{parent}/{name}"))
                    .or_default()
                    .push(before);
                root.get_or_insert_with(|| name.clone());
                let place = Place::new(content);
                if matches!(event, Event::Start(_)) {
                    stack.push((name, before, place));
                } else if let Some(message) = place.missing_at_end() {
                    reports.push(positions.line_at(before), &name, message);
                }
            }
            Event::End(_) => {
                if let Some((name, at, place)) = stack.pop() {
                    if let Some(message) = place.missing_at_end() {
                        reports.push(positions.line_at(at), &name, message);
                    }
                }
            }
            Event::Text(ref t) if !t.trim().is_empty() => {
                let skipped = t.len() - t.trim_start().len();
                text_inside(&mut stack, &mut reports, &positions, before + skipped);
            }
            Event::CData(_) | Event::GeneralRef(_) => {
                text_inside(&mut stack, &mut reports, &positions, before);
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if let Some((name, at, _)) = stack.last() {
        return Err(MdError::new(
            Some(positions.line_at(*at)),
            MdErrorKind::Xml(format!("<{name}> is not closed before the end of the file")),
        ));
    }
    match root {
        Some(root) => Ok(Scan {
            root,
            positions,
            schema_problems: reports.into_problems(),
        }),
        None => Err(MdError::new(
            None,
            MdErrorKind::Xml("no root element".into()),
        )),
    }
}

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
            // xs:double spells infinities this way; Rust's parser does not accept them.
            Some("INF") => Ok(Some(f64::INFINITY)),
            Some("-INF") => Ok(Some(f64::NEG_INFINITY)),
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
            None => pos
                .second(&e.to_string())
                .unwrap_or_else(|| MdError::new(None, MdErrorKind::Xml(e.to_string()))),
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
    let count = [
        t.real.is_some(),
        t.integer.is_some(),
        t.boolean.is_some(),
        t.string.is_some(),
        t.enumeration.is_some(),
    ]
    .iter()
    .filter(|&&b| b)
    .count();
    if count != 1 {
        return Err(c.element_error(format!(
            "needs exactly one of <Real>, <Integer>, <Boolean>, <String>, <Enumeration>, found {count}"
        )));
    }
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
    let count = [
        v.real.is_some(),
        v.integer.is_some(),
        v.boolean.is_some(),
        v.string.is_some(),
        v.enumeration.is_some(),
    ]
    .iter()
    .filter(|&&b| b)
    .count();
    if count != 1 {
        return Err(c.element_error(format!(
            "needs exactly one of <Real>, <Integer>, <Boolean>, <String>, <Enumeration>, found {count}"
        )));
    }
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
