//! The XML as serde sees it: every attribute an optional string.
//!
//! Values are read as text and converted in `parse.rs`, which knows the element's line
//! and can say exactly which attribute of which variable is wrong; serde's own number
//! parsing would only report "invalid digit" without either.

use serde::Deserialize;

/// Attribute text, absent or present.
type Attr = Option<String>;

#[derive(Debug, Deserialize)]
pub(super) struct RawModelDescription {
    #[serde(rename = "@fmiVersion")]
    pub fmi_version: Attr,
    #[serde(rename = "@modelName")]
    pub model_name: Attr,
    #[serde(rename = "@guid")]
    pub guid: Attr,
    #[serde(rename = "@description")]
    pub description: Attr,
    #[serde(rename = "@author")]
    pub author: Attr,
    #[serde(rename = "@version")]
    pub version: Attr,
    #[serde(rename = "@generationTool")]
    pub generation_tool: Attr,
    #[serde(rename = "@generationDateAndTime")]
    pub generation_date_and_time: Attr,
    #[serde(rename = "@variableNamingConvention")]
    pub variable_naming_convention: Attr,
    #[serde(rename = "@numberOfEventIndicators")]
    pub number_of_event_indicators: Attr,
    #[serde(rename = "CoSimulation")]
    pub co_simulation: Option<RawCoSimulation>,
    #[serde(rename = "ModelExchange")]
    pub model_exchange: Option<RawModelExchange>,
    #[serde(rename = "UnitDefinitions")]
    pub unit_definitions: Option<RawUnitDefinitions>,
    #[serde(rename = "TypeDefinitions")]
    pub type_definitions: Option<RawTypeDefinitions>,
    #[serde(rename = "LogCategories")]
    pub log_categories: Option<RawLogCategories>,
    #[serde(rename = "DefaultExperiment")]
    pub default_experiment: Option<RawDefaultExperiment>,
    #[serde(rename = "ModelVariables")]
    pub model_variables: Option<RawModelVariables>,
    #[serde(rename = "ModelStructure")]
    pub model_structure: Option<RawModelStructure>,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawCoSimulation {
    #[serde(rename = "@modelIdentifier")]
    pub model_identifier: Attr,
    #[serde(rename = "@needsExecutionTool")]
    pub needs_execution_tool: Attr,
    #[serde(rename = "@canHandleVariableCommunicationStepSize")]
    pub can_handle_variable_communication_step_size: Attr,
    #[serde(rename = "@canInterpolateInputs")]
    pub can_interpolate_inputs: Attr,
    #[serde(rename = "@maxOutputDerivativeOrder")]
    pub max_output_derivative_order: Attr,
    #[serde(rename = "@canRunAsynchronuously")]
    pub can_run_asynchronuously: Attr,
    #[serde(rename = "@canBeInstantiatedOnlyOncePerProcess")]
    pub can_be_instantiated_only_once_per_process: Attr,
    #[serde(rename = "@canNotUseMemoryManagementFunctions")]
    pub can_not_use_memory_management_functions: Attr,
    #[serde(rename = "@canGetAndSetFMUstate")]
    pub can_get_and_set_fmu_state: Attr,
    #[serde(rename = "@canSerializeFMUstate")]
    pub can_serialize_fmu_state: Attr,
    #[serde(rename = "@providesDirectionalDerivative")]
    pub provides_directional_derivative: Attr,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawModelExchange {
    #[serde(rename = "@modelIdentifier")]
    pub model_identifier: Attr,
    #[serde(rename = "@needsExecutionTool")]
    pub needs_execution_tool: Attr,
    #[serde(rename = "@completedIntegratorStepNotNeeded")]
    pub completed_integrator_step_not_needed: Attr,
    #[serde(rename = "@canBeInstantiatedOnlyOncePerProcess")]
    pub can_be_instantiated_only_once_per_process: Attr,
    #[serde(rename = "@canNotUseMemoryManagementFunctions")]
    pub can_not_use_memory_management_functions: Attr,
    #[serde(rename = "@canGetAndSetFMUstate")]
    pub can_get_and_set_fmu_state: Attr,
    #[serde(rename = "@canSerializeFMUstate")]
    pub can_serialize_fmu_state: Attr,
    #[serde(rename = "@providesDirectionalDerivative")]
    pub provides_directional_derivative: Attr,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawUnitDefinitions {
    #[serde(rename = "Unit", default)]
    pub units: Vec<RawUnit>,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawUnit {
    #[serde(rename = "@name")]
    pub name: Attr,
    #[serde(rename = "BaseUnit")]
    pub base_unit: Option<RawBaseUnit>,
    #[serde(rename = "DisplayUnit", default)]
    pub display_units: Vec<RawDisplayUnit>,
}

#[derive(Debug, Deserialize)]
#[allow(non_snake_case)] // Mirrors the SI symbols of the schema.
pub(super) struct RawBaseUnit {
    #[serde(rename = "@kg")]
    pub kg: Attr,
    #[serde(rename = "@m")]
    pub m: Attr,
    #[serde(rename = "@s")]
    pub s: Attr,
    #[serde(rename = "@A")]
    pub A: Attr,
    #[serde(rename = "@K")]
    pub K: Attr,
    #[serde(rename = "@mol")]
    pub mol: Attr,
    #[serde(rename = "@cd")]
    pub cd: Attr,
    #[serde(rename = "@rad")]
    pub rad: Attr,
    #[serde(rename = "@factor")]
    pub factor: Attr,
    #[serde(rename = "@offset")]
    pub offset: Attr,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawDisplayUnit {
    #[serde(rename = "@name")]
    pub name: Attr,
    #[serde(rename = "@factor")]
    pub factor: Attr,
    #[serde(rename = "@offset")]
    pub offset: Attr,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawTypeDefinitions {
    #[serde(rename = "SimpleType", default)]
    pub simple_types: Vec<RawSimpleType>,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawSimpleType {
    #[serde(rename = "@name")]
    pub name: Attr,
    #[serde(rename = "@description")]
    pub description: Attr,
    #[serde(rename = "Real")]
    pub real: Option<RawReal>,
    #[serde(rename = "Integer")]
    pub integer: Option<RawInteger>,
    #[serde(rename = "Boolean")]
    pub boolean: Option<RawBoolean>,
    #[serde(rename = "String")]
    pub string: Option<RawString>,
    #[serde(rename = "Enumeration")]
    pub enumeration: Option<RawEnumeration>,
}

/// `<Real>` as a type definition or a variable's type element (the union of both).
#[derive(Debug, Deserialize)]
pub(super) struct RawReal {
    #[serde(rename = "@declaredType")]
    pub declared_type: Attr,
    #[serde(rename = "@quantity")]
    pub quantity: Attr,
    #[serde(rename = "@unit")]
    pub unit: Attr,
    #[serde(rename = "@displayUnit")]
    pub display_unit: Attr,
    #[serde(rename = "@relativeQuantity")]
    pub relative_quantity: Attr,
    #[serde(rename = "@min")]
    pub min: Attr,
    #[serde(rename = "@max")]
    pub max: Attr,
    #[serde(rename = "@nominal")]
    pub nominal: Attr,
    #[serde(rename = "@unbounded")]
    pub unbounded: Attr,
    #[serde(rename = "@start")]
    pub start: Attr,
    #[serde(rename = "@derivative")]
    pub derivative: Attr,
}

/// `<Integer>` as a type definition or a variable's type element.
#[derive(Debug, Deserialize)]
pub(super) struct RawInteger {
    #[serde(rename = "@declaredType")]
    pub declared_type: Attr,
    #[serde(rename = "@quantity")]
    pub quantity: Attr,
    #[serde(rename = "@min")]
    pub min: Attr,
    #[serde(rename = "@max")]
    pub max: Attr,
    #[serde(rename = "@start")]
    pub start: Attr,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawBoolean {
    #[serde(rename = "@start")]
    pub start: Attr,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawString {
    #[serde(rename = "@start")]
    pub start: Attr,
}

/// `<Enumeration>` as a type definition (with items) or a variable's type element.
#[derive(Debug, Deserialize)]
pub(super) struct RawEnumeration {
    #[serde(rename = "@declaredType")]
    pub declared_type: Attr,
    #[serde(rename = "@quantity")]
    pub quantity: Attr,
    #[serde(rename = "@min")]
    pub min: Attr,
    #[serde(rename = "@max")]
    pub max: Attr,
    #[serde(rename = "@start")]
    pub start: Attr,
    #[serde(rename = "Item", default)]
    pub items: Vec<RawItem>,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawItem {
    #[serde(rename = "@name")]
    pub name: Attr,
    #[serde(rename = "@value")]
    pub value: Attr,
    #[serde(rename = "@description")]
    pub description: Attr,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawLogCategories {
    #[serde(rename = "Category", default)]
    pub categories: Vec<RawCategory>,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawCategory {
    #[serde(rename = "@name")]
    pub name: Attr,
    #[serde(rename = "@description")]
    pub description: Attr,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawDefaultExperiment {
    #[serde(rename = "@startTime")]
    pub start_time: Attr,
    #[serde(rename = "@stopTime")]
    pub stop_time: Attr,
    #[serde(rename = "@tolerance")]
    pub tolerance: Attr,
    #[serde(rename = "@stepSize")]
    pub step_size: Attr,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawModelVariables {
    #[serde(rename = "ScalarVariable", default)]
    pub variables: Vec<RawScalarVariable>,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawScalarVariable {
    #[serde(rename = "@name")]
    pub name: Attr,
    #[serde(rename = "@valueReference")]
    pub value_reference: Attr,
    #[serde(rename = "@description")]
    pub description: Attr,
    #[serde(rename = "@causality")]
    pub causality: Attr,
    #[serde(rename = "@variability")]
    pub variability: Attr,
    #[serde(rename = "@initial")]
    pub initial: Attr,
    #[serde(rename = "Real")]
    pub real: Option<RawReal>,
    #[serde(rename = "Integer")]
    pub integer: Option<RawInteger>,
    #[serde(rename = "Boolean")]
    pub boolean: Option<RawBoolean>,
    #[serde(rename = "String")]
    pub string: Option<RawString>,
    #[serde(rename = "Enumeration")]
    pub enumeration: Option<RawEnumeration>,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawModelStructure {
    #[serde(rename = "Outputs")]
    pub outputs: Option<RawUnknowns>,
    #[serde(rename = "Derivatives")]
    pub derivatives: Option<RawUnknowns>,
    #[serde(rename = "InitialUnknowns")]
    pub initial_unknowns: Option<RawUnknowns>,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawUnknowns {
    #[serde(rename = "Unknown", default)]
    pub unknowns: Vec<RawUnknown>,
}

#[derive(Debug, Deserialize)]
pub(super) struct RawUnknown {
    #[serde(rename = "@index")]
    pub index: Attr,
    #[serde(rename = "@dependencies")]
    pub dependencies: Attr,
    #[serde(rename = "@dependenciesKind")]
    pub dependencies_kind: Attr,
}
