//! Parsing the realistic fixture into the expected structs, and parse errors of broken
//! descriptions with their line numbers.

use fmi2_md::{Causality, VarType, Variability};
use fmi2_md::{
    DependencyKind, Initial, MdErrorKind, ModelDescription, SimpleTypeKind, VariableKind,
    VariableNamingConvention,
};

const VALID: &str = include_str!("fixtures/valid.xml");
const VALID_PATH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/valid.xml");

/// The fixture with one exact, asserted-present substitution.
fn edited(from: &str, to: &str) -> String {
    assert!(VALID.contains(from), "fixture does not contain {from:?}");
    VALID.replacen(from, to, 1)
}

#[test]
fn valid_fixture_parses_into_expected_structs() {
    let md = ModelDescription::parse(VALID).unwrap();
    assert_eq!(md.fmi_version, "2.0");
    assert_eq!(md.model_name, "MiniPlatform");
    assert_eq!(md.guid, "{6f1c3a52-8d0e-4b7a-9e21-3c5d7a1b2f90}");
    assert_eq!(md.author.as_deref(), Some("ckcm project"));
    assert_eq!(
        md.generation_date_and_time.as_deref(),
        Some("2026-11-23T12:00:00Z")
    );
    assert_eq!(
        md.variable_naming_convention,
        VariableNamingConvention::Structured
    );
    assert_eq!(md.number_of_event_indicators, 0);

    let cs = md.co_simulation.as_ref().unwrap();
    assert_eq!(cs.model_identifier, "MiniPlatform");
    assert!(cs.can_handle_variable_communication_step_size);
    assert!(cs.can_get_and_set_fmu_state && cs.can_serialize_fmu_state);
    assert!(
        !cs.can_interpolate_inputs
            && !cs.needs_execution_tool
            && !cs.provides_directional_derivative
    );
    assert!(md.model_exchange.is_none());

    assert_eq!(md.unit_definitions.len(), 4);
    let newton = md.unit("N").unwrap().base_unit.as_ref().unwrap();
    assert_eq!((newton.kg, newton.m, newton.s, newton.rad), (1, 1, -2, 0));
    assert_eq!((newton.factor, newton.offset), (1.0, 0.0));
    let rad = md.unit("rad").unwrap();
    assert_eq!(rad.display_units.len(), 1);
    assert_eq!(rad.display_units[0].name, "deg");
    assert!((rad.display_units[0].factor - 180.0 / std::f64::consts::PI).abs() < 1e-12);

    assert_eq!(md.type_definitions.len(), 3);
    match &md.simple_type("Angle").unwrap().kind {
        SimpleTypeKind::Real {
            unit, display_unit, ..
        } => {
            assert_eq!(
                (unit.as_deref(), display_unit.as_deref()),
                (Some("rad"), Some("deg"))
            );
        }
        other => panic!("Angle is {other:?}"),
    }
    let traj = md.simple_type("Trajectory").unwrap();
    assert_eq!(traj.description.as_deref(), Some("Reference trajectory"));
    match &traj.kind {
        SimpleTypeKind::Enumeration { items, .. } => {
            let names: Vec<_> = items.iter().map(|i| (i.name.as_str(), i.value)).collect();
            assert_eq!(names, [("hold", 1), ("line", 2), ("circle", 3)]);
            assert_eq!(items[0].description.as_deref(), Some("stay at home"));
        }
        other => panic!("Trajectory is {other:?}"),
    }
    assert_eq!(md.enumeration_item("trajectory", "circle"), Some(3));
    assert_eq!(md.enumeration_item("trajectory", "external"), None);
    assert_eq!(md.enumeration_item("total_mass", "circle"), None);
    assert_eq!(md.enumeration_item("no_such_variable", "line"), None);
    assert_eq!(md.log_categories.len(), 2);
    assert_eq!(md.log_categories[1].name, "logAll");
    let de = md.default_experiment.as_ref().unwrap();
    assert_eq!(
        (de.start_time, de.stop_time, de.step_size, de.tolerance),
        (Some(0.0), Some(15.0), Some(0.001), None)
    );

    assert_eq!(md.model_variables.len(), 18);
    let f1 = &md.model_variables[0];
    assert_eq!(f1.name, "force[1]");
    assert_eq!(f1.value_reference, 1);
    assert_eq!(f1.description.as_deref(), Some("actuator force 1"));
    assert_eq!(
        (f1.causality, f1.variability, f1.initial),
        (Causality::Input, Variability::Continuous, None)
    );
    assert_eq!(f1.line, Some(45));
    assert_eq!(
        f1.kind,
        VariableKind::Real {
            declared_type: Some("Force".into()),
            quantity: None,
            unit: None,
            display_unit: None,
            start: Some(0.0),
            min: None,
            max: None,
            nominal: None,
            derivative: None,
        }
    );
    let x4 = md.variable_by_name("x[4]").unwrap();
    assert_eq!(x4.causality, Causality::Output);
    assert_eq!(
        x4.initial,
        Some(Initial::Calculated),
        "default initial of a continuous output"
    );
    assert!(
        matches!(&x4.kind, VariableKind::Real { declared_type: Some(t), start: None, .. } if t == "Angle")
    );

    let mass = md.variable_by_vr(VarType::Real, 21).unwrap();
    assert_eq!(mass.name, "mass");
    assert_eq!(mass.initial, Some(Initial::Exact));
    assert!(
        matches!(mass.kind, VariableKind::Real { start: Some(s), min: Some(m), .. } if s == 4.92 && m == 0.0)
    );
    let traj = md.variable_by_name("trajectory").unwrap();
    assert_eq!(traj.var_type(), VarType::Enumeration);
    assert_eq!(
        traj.kind,
        VariableKind::Enumeration {
            declared_type: "Trajectory".into(),
            start: Some(2),
            min: None,
            max: None
        }
    );
    assert_eq!(
        md.variable_by_vr(VarType::Integer, 22)
            .map(|v| v.name.as_str()),
        Some("trajectory")
    );
    assert_eq!(
        md.variable_by_name("learning").unwrap().kind,
        VariableKind::Boolean { start: Some(true) }
    );
    assert_eq!(
        md.variable_by_name("learning").unwrap().variability,
        Variability::Tunable
    );
    assert_eq!(
        md.variable_by_name("trials").unwrap().kind,
        VariableKind::Integer {
            declared_type: None,
            start: Some(3),
            min: Some(1),
            max: Some(100)
        }
    );
    let total = md.variable_by_name("total_mass").unwrap();
    assert_eq!(
        (total.causality, total.initial),
        (Causality::CalculatedParameter, Some(Initial::Calculated))
    );
    assert_eq!(
        md.variable_by_name("label").unwrap().kind,
        VariableKind::String {
            start: Some("mini".into())
        }
    );
    assert!(md.variable_by_name("nope").is_none());
    assert!(md.variable_by_vr(VarType::Boolean, 21).is_none());

    let ms = &md.model_structure;
    assert_eq!(
        ms.outputs.iter().map(|u| u.index).collect::<Vec<_>>(),
        (7..=12).collect::<Vec<_>>()
    );
    assert_eq!(ms.outputs[0].dependencies, Some(vec![]));
    assert!(ms.derivatives.is_empty());
    assert_eq!(ms.initial_unknowns.len(), 7);
    assert_eq!(ms.initial_unknowns[0].dependencies, Some(vec![13]));
    assert_eq!(
        ms.initial_unknowns[0].dependencies_kind,
        Some(vec![DependencyKind::Dependent])
    );
    assert_eq!(ms.initial_unknowns[6].index, 17);
    assert_eq!(ms.initial_unknowns[6].dependencies_kind, None);

    assert_eq!(md.validate(), vec![], "the fixture is valid");
}

#[test]
fn from_file_matches_parse() {
    let from_file = ModelDescription::from_file(VALID_PATH).unwrap();
    assert_eq!(from_file, ModelDescription::parse(VALID).unwrap());
}

#[test]
fn missing_file_names_the_file() {
    let err = ModelDescription::from_file("/nonexistent/modelDescription.xml").unwrap_err();
    assert!(matches!(*err.kind, MdErrorKind::Io(_)));
    assert!(
        err.to_string()
            .starts_with("/nonexistent/modelDescription.xml: cannot read"),
        "{err}"
    );
}

/// Malformed attributes are refused with the line of the faulty attribute, also inside a
/// start tag over several lines (the root's spans lines 2–12).
#[test]
fn malformed_attributes_report_their_line() {
    for (from, to, line, words) in [
        (
            "  author=\"ckcm project\"\n",
            "  author=\"ckcm project\"\n  author=\"again\"\n",
            8,
            "duplicated attribute",
        ),
        (
            "  version=\"0.1.0\"\n",
            "  version=\"0.1.0\"\n  novalue\n",
            // Where the `=` should have been: the next attribute's line.
            10,
            "must be directly followed by `=`",
        ),
        (
            "name=\"x[1]\" valueReference=\"11\"",
            "name=\"x[1]\" valueReference=11",
            69,
            "",
        ),
    ] {
        let err = ModelDescription::parse(&edited(from, to)).unwrap_err();
        assert!(matches!(*err.kind, MdErrorKind::Xml(_)), "{err:?}");
        assert_eq!(err.line, Some(line), "{err}");
        assert!(err.to_string().contains(words), "{err}");
    }
}

#[test]
fn malformed_xml_reports_its_line() {
    let xml = edited(
        "    </ScalarVariable>\n    <!-- index 3 -->",
        "    </ScalarVariabel>\n    <!-- index 3 -->",
    );
    let err = ModelDescription::parse(&xml).unwrap_err();
    assert!(matches!(*err.kind, MdErrorKind::Xml(_)), "{err:?}");
    assert_eq!(err.line, Some(51), "{err}");
    assert!(
        err.to_string().starts_with("line 51: malformed XML"),
        "{err}"
    );

    let truncated = &VALID[..VALID.find("<ModelStructure>").unwrap()];
    let err = ModelDescription::parse(truncated).unwrap_err();
    assert!(matches!(*err.kind, MdErrorKind::Xml(_)), "{err:?}");
    assert!(err.to_string().contains("not closed"), "{err}");

    let err = ModelDescription::parse("<fmiModelDescription fmiVersion=\"2.0\"\n  guid=\"x>\n")
        .unwrap_err();
    assert!(matches!(*err.kind, MdErrorKind::Xml(_)), "{err:?}");
    assert_eq!(err.line, Some(1));
}

#[test]
fn fmi1_is_a_distinct_error() {
    let err =
        ModelDescription::parse(&edited("fmiVersion=\"2.0\"", "fmiVersion=\"1.0\"")).unwrap_err();
    assert_eq!(*err.kind, MdErrorKind::Fmi1("1.0".into()));
    assert_eq!(err.line, Some(3));
    assert_eq!(
        err.to_string(),
        "line 3: FMI 1.0 model descriptions are not supported (fmiVersion=\"1.0\")"
    );

    let err =
        ModelDescription::parse(&edited("fmiVersion=\"2.0\"", "fmiVersion=\"3.0\"")).unwrap_err();
    assert_eq!(*err.kind, MdErrorKind::UnsupportedVersion("3.0".into()));

    let err = ModelDescription::parse("<fmiModelDescription modelName=\"m\"/>").unwrap_err();
    assert!(
        err.to_string()
            .contains("missing required attribute 'fmiVersion'"),
        "{err}"
    );
}

#[test]
fn model_exchange_only_is_a_distinct_error() {
    let xml = edited("<CoSimulation", "<ModelExchange");
    let err = ModelDescription::parse(&xml).unwrap_err();
    assert_eq!(*err.kind, MdErrorKind::ModelExchangeOnly);
    assert!(
        err.to_string()
            .ends_with("no <CoSimulation> element: this FMU is Model Exchange only"),
        "{err}"
    );

    let none = edited(
        "  <CoSimulation\n    modelIdentifier=\"MiniPlatform\"\n    canHandleVariableCommunicationStepSize=\"true\"\n    canGetAndSetFMUstate=\"true\"\n    canSerializeFMUstate=\"true\"/>\n",
        "",
    );
    assert_eq!(
        *ModelDescription::parse(&none).unwrap_err().kind,
        MdErrorKind::NoCoSimulation
    );
}

#[test]
fn wrong_root_is_rejected() {
    let err = ModelDescription::parse("<?xml version=\"1.0\"?>\n\n<fmiTerminals/>").unwrap_err();
    assert_eq!(*err.kind, MdErrorKind::WrongRoot("fmiTerminals".into()));
    assert_eq!(err.line, Some(3));
}

#[test]
fn unknown_causality_names_variable_line_and_value() {
    let xml = edited(
        "causality=\"input\" description=\"actuator force 1\"",
        "causality=\"inptu\" description=\"actuator force 1\"",
    );
    let err = ModelDescription::parse(&xml).unwrap_err();
    assert_eq!(err.line, Some(45));
    assert!(
        err.to_string()
            .starts_with("line 45: ScalarVariable 'force[1]': invalid causality 'inptu'"),
        "{err}"
    );

    // tempfile is only a dependency with the `import` feature; a per-process name suffices.
    let path = std::env::temp_dir().join(format!(
        "fmi2-md-test-{}-modelDescription.xml",
        std::process::id()
    ));
    std::fs::write(&path, &xml).unwrap();
    let err = ModelDescription::from_file(&path).unwrap_err();
    std::fs::remove_file(&path).unwrap();
    let expected = format!(
        "{}:45: ScalarVariable 'force[1]': invalid causality 'inptu'",
        path.display()
    );
    assert!(err.to_string().starts_with(&expected), "{err}");
}

#[test]
fn unreadable_numbers_name_the_attribute_line() {
    let xml = edited(
        "<Real unit=\"kg\" start=\"4.92\" min=\"0\"/>",
        "<Real unit=\"kg\"\n        start=\"4,92\" min=\"0\"/>",
    );
    let err = ModelDescription::parse(&xml).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("ScalarVariable 'mass': invalid start '4,92' (expected a real number)"),
        "{msg}"
    );
    let mass_line = VALID
        .lines()
        .position(|l| l.contains("name=\"mass\""))
        .unwrap()
        + 1;
    assert_eq!(
        err.line,
        Some(mass_line + 2),
        "the line of the start attribute"
    );

    let err = ModelDescription::parse(&edited("valueReference=\"21\"", "valueReference=\"-21\""))
        .unwrap_err();
    assert!(
        err.to_string().contains("invalid valueReference '-21'"),
        "{err}"
    );
    let err = ModelDescription::parse(&edited(
        "<Boolean start=\"true\"/>",
        "<Boolean start=\"yes\"/>",
    ))
    .unwrap_err();
    assert!(
        err.to_string()
            .contains("ScalarVariable 'learning': invalid start 'yes'"),
        "{err}"
    );
}

#[test]
fn variable_without_type_element_is_an_error() {
    let err = ModelDescription::parse(&edited("      <String start=\"mini\"/>\n", "")).unwrap_err();
    assert!(
        err.to_string()
            .contains("ScalarVariable 'label': needs exactly one of"),
        "{err}"
    );
}
