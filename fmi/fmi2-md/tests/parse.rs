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
        // The duplicate at the very start of its line.
        (
            "  author=\"ckcm project\"\n",
            "  author=\"ckcm project\"\nauthor=\"again\"\n",
            8,
            "duplicated attribute",
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
    // Only xs:double's spellings of the special values, not the others Rust would read.
    for (text, value) in [
        ("INF", f64::INFINITY),
        ("-INF", f64::NEG_INFINITY),
        ("NaN", f64::NAN),
    ] {
        let md = ModelDescription::parse(&edited(
            "<Real unit=\"kg\" start=\"4.92\" min=\"0\"/>",
            &format!("<Real unit=\"kg\" start=\"4.92\" min=\"0\" nominal=\"{text}\"/>"),
        ))
        .unwrap();
        let nominal = match &md.variable_by_name("mass").unwrap().kind {
            VariableKind::Real { nominal, .. } => nominal.unwrap(),
            other => panic!("{other:?}"),
        };
        assert_eq!(nominal.to_bits(), value.to_bits(), "{text}");
    }
    for text in ["inf", "Infinity", "+INF", "nan", "NAN", "1.0f"] {
        let err = ModelDescription::parse(&edited(
            "<Real unit=\"kg\" start=\"4.92\" min=\"0\"/>",
            &format!("<Real unit=\"kg\" start=\"{text}\" min=\"0\"/>"),
        ))
        .unwrap_err();
        assert!(
            err.to_string().contains(&format!(
                "ScalarVariable 'mass': invalid start '{text}' (expected a real number)"
            )),
            "{err}"
        );
    }
    // Also when the attribute starts its line.
    let xml = edited(
        "<Real unit=\"kg\" start=\"4.92\" min=\"0\"/>",
        "<Real unit=\"kg\"\nstart=\"4,92\" min=\"0\"/>",
    );
    let err = ModelDescription::parse(&xml).unwrap_err();
    assert_eq!(err.line, Some(mass_line + 2), "{err}");

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

    // Units and types are named once their name is known, as variables are.
    for (from, to, named) in [
        (
            "<BaseUnit kg=\"1\" m=\"1\" s=\"-2\"/>",
            "<BaseUnit kg=\"one\" m=\"1\" s=\"-2\"/>",
            "line 19: Unit 'N': invalid kg 'one'",
        ),
        (
            "<Real quantity=\"Force\" unit=\"N\"/>",
            "<Real quantity=\"Force\" unit=\"N\" max=\"lots\"/>",
            "line 28: SimpleType 'Force': invalid max 'lots'",
        ),
    ] {
        let err = ModelDescription::parse(&edited(from, to)).unwrap_err();
        assert!(err.to_string().starts_with(named), "{err}");
    }
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

/// A description holding what the realistic fixture lacks: `local` and `independent`
/// variables, constants, `initial="approx"`, the `dependenciesKind` values other than
/// `dependent`, a ModelExchange interface beside the co-simulation one, xs:double's
/// infinities, and bounds and units taken from declared types. Each value is read as
/// itself, the standard's causality/variability table accepts every combination used, and
/// the lookups fall back on the declared type.
const EVERY_KIND: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="EveryKind" guid="{every-kind}">
  <ModelExchange modelIdentifier="EveryKindME" completedIntegratorStepNotNeeded="true"
    canGetAndSetFMUstate="true"/>
  <CoSimulation modelIdentifier="EveryKindCS"/>
  <UnitDefinitions>
    <Unit name="m"/>
    <Unit name="mm"><BaseUnit m="1" factor="0.001"/></Unit>
  </UnitDefinitions>
  <TypeDefinitions>
    <SimpleType name="Length"><Real unit="m" min="0.5" max="2"/></SimpleType>
    <SimpleType name="Count"><Integer min="1" max="9"/></SimpleType>
  </TypeDefinitions>
  <ModelVariables>
    <ScalarVariable name="time" valueReference="0" causality="independent" variability="continuous">
      <Real/>
    </ScalarVariable>
    <ScalarVariable name="one" valueReference="1" causality="output" variability="constant">
      <Real start="1"/>
    </ScalarVariable>
    <ScalarVariable name="guess" valueReference="2" causality="local" initial="approx">
      <Real start="0"/>
    </ScalarVariable>
    <ScalarVariable name="length" valueReference="3" causality="parameter" variability="fixed">
      <Real declaredType="Length" start="1"/>
    </ScalarVariable>
    <ScalarVariable name="count" valueReference="4" causality="parameter" variability="tunable">
      <Integer declaredType="Count" start="3"/>
    </ScalarVariable>
    <ScalarVariable name="u" valueReference="5" causality="input" variability="discrete">
      <Real start="0" min="-INF" max="INF"/>
    </ScalarVariable>
    <ScalarVariable name="y" valueReference="6" causality="output">
      <Real declaredType="Length" min="0" unit="mm"/>
    </ScalarVariable>
    <ScalarVariable name="local_constant" valueReference="7" variability="constant">
      <Real start="2"/>
    </ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs>
      <Unknown index="2" dependencies=""/>
      <Unknown index="7" dependencies="6 6 6 6 6"
        dependenciesKind="dependent constant fixed tunable discrete"/>
    </Outputs>
    <InitialUnknowns>
      <Unknown index="7" dependencies="4"/>
    </InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"#;

#[test]
fn every_kind_of_variable_and_dependency_reads_as_written() {
    use fmi2_md::{DependencyKind as K, default_initial};
    let md = ModelDescription::parse(EVERY_KIND).unwrap();
    assert_eq!(md.validate(), vec![]);

    let me = md.model_exchange.as_ref().unwrap();
    assert_eq!(me.model_identifier, "EveryKindME");
    assert!(me.completed_integrator_step_not_needed && me.can_get_and_set_fmu_state);
    // The co-simulation interface is the one a master loads.
    assert_eq!(md.model_identifier(), Some("EveryKindCS"));

    let v = |name: &str| md.variable_by_name(name).unwrap();
    let read = |name: &str| (v(name).causality, v(name).variability, v(name).initial);
    assert_eq!(
        read("time"),
        (Causality::Independent, Variability::Continuous, None)
    );
    assert_eq!(
        read("one"),
        (
            Causality::Output,
            Variability::Constant,
            Some(Initial::Exact)
        )
    );
    assert_eq!(
        read("guess"),
        (
            Causality::Local,
            Variability::Continuous,
            Some(Initial::Approx)
        )
    );
    assert_eq!(
        read("count"),
        (
            Causality::Parameter,
            Variability::Tunable,
            Some(Initial::Exact)
        )
    );
    assert_eq!(read("u"), (Causality::Input, Variability::Discrete, None));
    assert_eq!(
        read("local_constant"),
        (
            Causality::Local,
            Variability::Constant,
            Some(Initial::Exact)
        )
    );

    // Bounds: the variable's own, else its declared type's; xs:double's infinities.
    assert_eq!(md.range_of(v("length")), (Some(0.5), Some(2.0)));
    assert_eq!(md.range_of(v("count")), (Some(1.0), Some(9.0)));
    assert_eq!(md.range_of(v("y")), (Some(0.0), Some(2.0)));
    assert_eq!(
        md.range_of(v("u")),
        (Some(f64::NEG_INFINITY), Some(f64::INFINITY))
    );
    // Units: the variable's own, else its declared type's.
    assert_eq!(md.unit_of(v("length")), Some("m"));
    assert_eq!(md.unit_of(v("y")), Some("mm"));
    assert_eq!(md.unit_of(v("time")), None);
    assert_eq!(md.unit_of(v("count")), None);

    let y = &md.model_structure.outputs[1];
    assert_eq!(
        y.dependencies_kind.as_deref(),
        Some(&[K::Dependent, K::Constant, K::Fixed, K::Tunable, K::Discrete][..])
    );

    // The defaults of the standard's table (FMI 2.0, section 2.2.7: cases A, B and C give
    // exact, calculated and calculated; D, E and the illegal combinations none).
    use Causality as C;
    use Variability as V;
    let causalities = [
        C::Parameter,
        C::CalculatedParameter,
        C::Input,
        C::Output,
        C::Local,
        C::Independent,
    ];
    let (a, b, c) = (
        Some(Initial::Exact),
        Some(Initial::Calculated),
        Some(Initial::Calculated),
    );
    for (variability, row) in [
        (V::Constant, [None, None, None, a, a, None]),
        (V::Fixed, [a, b, None, None, b, None]),
        (V::Tunable, [a, b, None, None, b, None]),
        (V::Discrete, [None, None, None, c, c, None]),
        (V::Continuous, [None, None, None, c, c, None]),
    ] {
        for (causality, expected) in causalities.into_iter().zip(row) {
            assert_eq!(
                default_initial(causality, variability),
                expected,
                "{causality:?} {variability:?}"
            );
        }
    }
}
