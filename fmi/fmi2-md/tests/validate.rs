//! `validate` reports each broken rule, and all of them at once.

use fmi2_md::{ModelDescription, Problem};

const VALID: &str = include_str!("fixtures/valid.xml");

/// The fixture with exact, asserted-present substitutions applied in order.
fn edited(edits: &[(&str, &str)]) -> String {
    let mut xml = VALID.to_owned();
    for (from, to) in edits {
        assert!(xml.contains(from), "fixture does not contain {from:?}");
        xml = xml.replacen(from, to, 1);
    }
    xml
}

fn problems(edits: &[(&str, &str)]) -> Vec<Problem> {
    ModelDescription::parse(&edited(edits))
        .expect("edits keep the XML parseable")
        .validate()
}

/// Asserts that exactly one problem mentions every fragment, and returns it.
fn find<'a>(problems: &'a [Problem], fragments: &[&str]) -> &'a Problem {
    let hits: Vec<_> = problems
        .iter()
        .filter(|p| fragments.iter().all(|f| p.to_string().contains(f)))
        .collect();
    assert_eq!(
        hits.len(),
        1,
        "expected one problem with {fragments:?}, got {problems:#?}"
    );
    hits[0]
}

const X1_OUTPUT: &str = "      <Unknown index=\"7\" dependencies=\"\"/>\n";
const FORCE3_START: &str = "actuator force 3\">\n      <Real declaredType=\"Force\" start=\"0\"/>";
const FORCE3_NO_START: &str = "actuator force 3\">\n      <Real declaredType=\"Force\"/>";

#[test]
fn duplicate_value_reference() {
    let p = problems(&[(
        "name=\"x[1]\" valueReference=\"11\"",
        "name=\"x[1]\" valueReference=\"1\"",
    )]);
    assert_eq!(p.len(), 1, "{p:#?}");
    let dup = find(
        &p,
        &[
            "ScalarVariable 'x[1]'",
            "valueReference 1 is already used",
            "'force[1]'",
        ],
    );
    assert_eq!(dup.line, Some(69));
}

#[test]
fn same_value_reference_in_another_base_type_is_fine() {
    // `learning` (Boolean) takes the vr of `mass` (Real): different accessors.
    let p = problems(&[("valueReference=\"23\"", "valueReference=\"21\"")]);
    assert_eq!(p, vec![]);
    // Integer and Enumeration share fmi2GetInteger, so they clash.
    let p = problems(&[("valueReference=\"24\"", "valueReference=\"22\"")]);
    find(
        &p,
        &[
            "ScalarVariable 'trials'",
            "valueReference 22 is already used",
            "'trajectory'",
        ],
    );
}

#[test]
fn duplicate_name() {
    let p = problems(&[("name=\"trials\"", "name=\"mass\"")]);
    find(
        &p,
        &[
            "ScalarVariable 'mass'",
            "name is already used by variable #13",
        ],
    );
}

#[test]
fn output_missing_from_model_structure() {
    let p = problems(&[(X1_OUTPUT, "")]);
    assert_eq!(p.len(), 1, "{p:#?}");
    find(
        &p,
        &["ModelStructure/Outputs", "'x[1]' (index 7) is missing"],
    );
}

#[test]
fn non_output_listed_and_wrong_order_in_outputs() {
    let p = problems(&[(
        X1_OUTPUT,
        "      <Unknown index=\"8\"/>\n      <Unknown index=\"7\"/>\n      <Unknown index=\"13\"/>\n",
    )]);
    find(
        &p,
        &[
            "ModelStructure/Outputs",
            "'x[2]' (index 8) is listed more than once",
        ],
    );
    find(
        &p,
        &[
            "ModelStructure/Outputs",
            "'mass' (index 13) must not be listed",
        ],
    );
    let p = problems(&[
        (X1_OUTPUT, ""),
        (
            "      <Unknown index=\"12\" dependencies=\"\"/>\n",
            "      <Unknown index=\"12\" dependencies=\"\"/>\n      <Unknown index=\"7\"/>\n",
        ),
    ]);
    find(&p, &["ModelStructure/Outputs", "ascending index order"]);
}

#[test]
fn out_of_range_indices() {
    let p = problems(&[(
        X1_OUTPUT,
        "      <Unknown index=\"7\" dependencies=\"0 19\"/>\n      <Unknown index=\"99\"/>\n",
    )]);
    find(&p, &["Unknown index=99 is out of range 1..=18"]);
    find(&p, &["dependency 0 is out of range"]);
    find(&p, &["dependency 19 is out of range"]);
}

#[test]
fn initial_unknowns_must_list_calculated_outputs_and_parameters() {
    let p = problems(&[("      <Unknown index=\"17\" dependencies=\"13\"/>\n", "")]);
    assert_eq!(p.len(), 1, "{p:#?}");
    find(
        &p,
        &[
            "ModelStructure/InitialUnknowns",
            "'total_mass' (index 17) is missing",
        ],
    );

    // An exact output must not appear among the InitialUnknowns.
    let p = problems(&[
        (
            "name=\"x[1]\" valueReference=\"11\" causality=\"output\"",
            "name=\"x[1]\" valueReference=\"11\" causality=\"output\" initial=\"exact\"",
        ),
        (
            "<Real quantity=\"Length\" unit=\"m\"/>",
            "<Real quantity=\"Length\" unit=\"m\" start=\"0\"/>",
        ),
    ]);
    assert_eq!(p.len(), 1, "{p:#?}");
    find(
        &p,
        &[
            "ModelStructure/InitialUnknowns",
            "'x[1]' (index 7) must not be listed",
        ],
    );
}

#[test]
fn bad_generation_date() {
    let p = problems(&[("2026-11-23T12:00:00Z", "2026-13-45 noon")]);
    assert_eq!(p.len(), 1, "{p:#?}");
    find(
        &p,
        &["generationDateAndTime '2026-13-45 noon' is not a valid xs:dateTime"],
    );
}

#[test]
fn input_without_start() {
    let p = problems(&[(FORCE3_START, FORCE3_NO_START)]);
    assert_eq!(p.len(), 1, "{p:#?}");
    let missing = find(
        &p,
        &["ScalarVariable 'force[3]'", "input has no start value"],
    );
    assert_eq!(missing.line, Some(53));
    assert!(
        missing
            .to_string()
            .starts_with("line 53: ScalarVariable 'force[3]': "),
        "{missing}"
    );
}

#[test]
fn causality_variability_initial_and_start_rules() {
    let p = problems(&[
        // A parameter must be fixed or tunable.
        (
            "name=\"mass\" valueReference=\"21\" causality=\"parameter\" variability=\"fixed\"",
            "name=\"mass\" valueReference=\"21\" causality=\"parameter\"",
        ),
        // An input takes no initial.
        (
            "causality=\"input\" description=\"actuator force 2\"",
            "causality=\"input\" initial=\"exact\" description=\"actuator force 2\"",
        ),
        // A calculated output must not have a start value.
        (
            "<Real quantity=\"Length\" unit=\"m\"/>",
            "<Real quantity=\"Length\" unit=\"m\" start=\"1\"/>",
        ),
        // An exact parameter needs one.
        (
            "<Integer start=\"3\" min=\"1\" max=\"100\"/>",
            "<Integer min=\"1\" max=\"100\"/>",
        ),
        // Only Reals can be continuous.
        (
            "name=\"learning\" valueReference=\"23\" causality=\"parameter\" variability=\"tunable\"",
            "name=\"learning\" valueReference=\"23\"",
        ),
    ]);
    find(
        &p,
        &[
            "ScalarVariable 'mass'",
            "parameter must be fixed or tunable (variability is continuous)",
        ],
    );
    find(
        &p,
        &[
            "ScalarVariable 'force[2]'",
            "initial=exact is not allowed for causality=input variability=continuous",
        ],
    );
    find(
        &p,
        &[
            "ScalarVariable 'x[1]'",
            "start value but initial is calculated",
        ],
    );
    find(
        &p,
        &[
            "ScalarVariable 'trials'",
            "initial=exact requires a start value",
        ],
    );
    find(
        &p,
        &[
            "ScalarVariable 'learning'",
            "continuous is only allowed for Real",
        ],
    );
}

#[test]
fn references_to_undefined_types_and_units() {
    let p = problems(&[
        (
            "<Real declaredType=\"Force\" start=\"0\"/>",
            "<Real declaredType=\"Forse\" start=\"0\"/>",
        ),
        (
            "<Real unit=\"kg\" start=\"4.92\" min=\"0\"/>",
            "<Real unit=\"kilogram\" start=\"4.92\" min=\"0\"/>",
        ),
        (
            "<Real quantity=\"Length\" unit=\"m\"/>",
            "<Real quantity=\"Length\" unit=\"m\" displayUnit=\"deg\"/>",
        ),
        (
            "<Enumeration declaredType=\"Trajectory\" start=\"2\"/>",
            "<Enumeration declaredType=\"Angle\" start=\"2\"/>",
        ),
        (
            "<Integer start=\"3\" min=\"1\" max=\"100\"/>",
            "<Integer start=\"300\" min=\"1\" max=\"100\"/>",
        ),
    ]);
    find(
        &p,
        &[
            "ScalarVariable 'force[1]'",
            "declaredType 'Forse' is not defined",
        ],
    );
    find(
        &p,
        &["ScalarVariable 'mass'", "unit 'kilogram' is not defined"],
    );
    find(
        &p,
        &[
            "ScalarVariable 'x[1]'",
            "displayUnit 'deg' is not defined for unit 'm'",
        ],
    );
    find(
        &p,
        &[
            "ScalarVariable 'trajectory'",
            "declaredType 'Angle' is not a Enumeration type",
        ],
    );
    find(
        &p,
        &["ScalarVariable 'trials'", "start 300 is above max 100"],
    );
}

#[test]
fn default_experiment_step_size_must_be_positive() {
    let p = problems(&[("stepSize=\"0.001\"", "stepSize=\"0\"")]);
    assert_eq!(p.len(), 1, "{p:#?}");
    find(&p, &["DefaultExperiment", "stepSize must be > 0"]);
    for tolerance in ["0", "-1e-6", "INF"] {
        let p = problems(&[(
            "stepSize=\"0.001\"",
            &format!("stepSize=\"0.001\" tolerance=\"{tolerance}\""),
        )]);
        assert_eq!(p.len(), 1, "{p:#?}");
        find(&p, &["DefaultExperiment", "tolerance must be > 0"]);
    }
    assert_eq!(
        problems(&[(
            "stepSize=\"0.001\"",
            "stepSize=\"0.001\" tolerance=\"1e-6\""
        )]),
        vec![]
    );
}

/// The binary's symbols and file names are built from the modelIdentifier, so it must be a
/// C identifier: a letter or underscore, then letters, digits and underscores.
#[test]
fn model_identifier_must_be_a_c_identifier() {
    for good in ["Mini_Platform", "_x", "x1"] {
        let p = problems(&[(
            "modelIdentifier=\"MiniPlatform\"",
            &format!("modelIdentifier=\"{good}\""),
        )]);
        assert_eq!(p, vec![], "{good}");
    }
    for bad in ["1x", "Mini-Platform", "Mini Platform", "Mini.Platform"] {
        let p = problems(&[(
            "modelIdentifier=\"MiniPlatform\"",
            &format!("modelIdentifier=\"{bad}\""),
        )]);
        assert_eq!(p.len(), 1, "{p:#?}");
        find(
            &p,
            &[&format!(
                "modelIdentifier '{bad}' is not a valid C identifier"
            )],
        );
    }
}

#[test]
fn several_problems_are_all_listed() {
    let p = problems(&[
        (
            "name=\"x[1]\" valueReference=\"11\"",
            "name=\"x[1]\" valueReference=\"1\"",
        ),
        (X1_OUTPUT, ""),
        ("2026-11-23T12:00:00Z", "23.11.2026"),
        (FORCE3_START, FORCE3_NO_START),
        ("stepSize=\"0.001\"", "stepSize=\"-1\""),
    ]);
    assert_eq!(p.len(), 5, "{p:#?}");
    find(&p, &["valueReference 1 is already used"]);
    find(&p, &["'x[1]' (index 7) is missing"]);
    find(&p, &["generationDateAndTime '23.11.2026'"]);
    find(&p, &["'force[3]'", "input has no start value"]);
    find(&p, &["stepSize must be > 0, is -1"]);
}

#[test]
fn elements_out_of_the_schemas_place() {
    let p = problems(&[
        (
            "    <!-- index 1 -->\n",
            "    <Foo><Bar/></Foo>\n    <!-- index 1 -->\n",
        ),
        (
            "<Real declaredType=\"Force\" start=\"0\"/>",
            "<Real declaredType=\"Force\" start=\"0\"><Real/></Real>",
        ),
        (
            "  <ModelVariables>\n",
            "  <VendorAnnotations><Tool name=\"t\"><Anything><Deeper/></Anything></Tool></VendorAnnotations>\n  <ModelVariables>\n",
        ),
    ]);
    assert_eq!(
        p.len(),
        2,
        "the <Tool>'s free content and <Bar> inside <Foo> are not reported: {p:#?}"
    );
    let foo = find(
        &p,
        &[
            "ModelVariables",
            "<Foo> is not allowed here",
            "allows <ScalarVariable>",
        ],
    );
    assert_eq!(foo.line, Some(45));
    let real = find(
        &p,
        &["Real: <Real> is not allowed here: this element holds no elements"],
    );
    assert_eq!(real.line, Some(48));
}

#[test]
fn a_flood_of_misplaced_elements_is_summarised() {
    // 150 tools with two elements each, where the schema allows one.
    let tools: String = (0..150)
        .map(|k| format!("<Tool name=\"t{k}\"><A/><B/></Tool>"))
        .collect();
    let p = problems(&[(
        "  <ModelVariables>\n",
        &format!("  <VendorAnnotations>{tools}</VendorAnnotations>\n  <ModelVariables>\n"),
    )]);
    assert_eq!(p.len(), 101, "{p:#?}");
    find(&p, &["50 more problems with the schema"]);
}

/// After the first element that breaks its parent's content model the parent's other
/// children are not reported (as libxml2 reports one such error per element), but their
/// own content still is.
#[test]
fn one_report_per_broken_parent() {
    let p = problems(&[
        (
            "    <!-- index 1 -->\n",
            "    <Foo/><Bar/>\n    <!-- index 1 -->\n",
        ),
        (
            "<Real declaredType=\"Force\" start=\"0\"/>",
            "<Real declaredType=\"Force\" start=\"0\"><Real/></Real>",
        ),
    ]);
    assert_eq!(p.len(), 2, "{p:#?}");
    find(&p, &["<Foo> is not allowed here"]);
    find(&p, &["Real: <Real> is not allowed here"]);
}

#[test]
fn order_and_counts_follow_the_schema() {
    let p = problems(&[
        (
            "  <DefaultExperiment startTime=\"0\" stopTime=\"15\" stepSize=\"0.001\"/>\n",
            "",
        ),
        // A refused element's attributes are not checked on top: `bogus` is not reported.
        (
            "  <UnitDefinitions>\n",
            "  <DefaultExperiment startTime=\"0\" stopTime=\"15\" stepSize=\"0.001\"/>\n  <UnitDefinitions bogus=\"1\">\n",
        ),
    ]);
    assert_eq!(p.len(), 1, "{p:#?}");
    let late = find(
        &p,
        &["<UnitDefinitions> is out of order: it must come before <DefaultExperiment>"],
    );
    assert_eq!(late.line, Some(19));

    // A second <DefaultExperiment> fails the typed parse; the error is the schema's, with
    // its line, not serde's "duplicate field" without one.
    let twice = edited(&[(
        "  <DefaultExperiment",
        "  <DefaultExperiment/>\n  <DefaultExperiment",
    )]);
    let err = ModelDescription::parse(&twice).unwrap_err().to_string();
    assert!(
        err.contains("line 43") && err.contains("<DefaultExperiment> is one too many"),
        "{err}"
    );

    // Two <CoSimulation> pass the schema's structure (it repeats the pair of
    // implementations); the streaming pass refuses the second at its line.
    let twice = edited(&[(
        "  <UnitDefinitions>\n",
        "  <CoSimulation modelIdentifier=\"Other\"/>\n  <UnitDefinitions>\n",
    )]);
    let err = ModelDescription::parse(&twice).unwrap_err().to_string();
    assert!(
        err.contains("line 18") && err.contains("a second <CoSimulation>"),
        "{err}"
    );

    let p = problems(&[(
        "<UnitDefinitions>\n    <Unit name=\"N\">",
        "<UnitDefinitions>\n    <Unit name=\"N\"><DisplayUnit name=\"kN\" factor=\"0.001\"/>",
    )]);
    find(
        &p,
        &[
            "line 19",
            "<BaseUnit> is out of order: it must come before <DisplayUnit>",
        ],
    );
    let p = problems(&[(
        "  <LogCategories>\n    <Category name=\"logStatusError\" description=\"errors\"/>\n    <Category name=\"logAll\"/>\n  </LogCategories>",
        "  <LogCategories>\n  </LogCategories>",
    )]);
    find(&p, &["line 38", "LogCategories: misses <Category>"]);
}

#[test]
fn attributes_the_schema_does_not_define() {
    let p = problems(&[
        (
            "  author=\"ckcm project\"\n",
            "  author=\"ckcm project\"\n  copyrite=\"2026\"\n",
        ),
        (
            "numberOfEventIndicators=\"0\">",
            "numberOfEventIndicators=\"0\" xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" \
             xsi:noNamespaceSchemaLocation=\"fmi2ModelDescription.xsd\">",
        ),
        (
            "<Real declaredType=\"Force\" start=\"0\"/>",
            "<Real declaredType=\"Force\" start=\"0\" variability=\"fixed\"/>",
        ),
    ]);
    assert_eq!(
        p.len(),
        2,
        "namespace and xsi attributes are every element's: {p:#?}"
    );
    // The attribute's own line, inside a start tag over several lines.
    let root = find(
        &p,
        &["fmiModelDescription: attribute 'copyrite' is not defined for <fmiModelDescription>"],
    );
    assert_eq!(root.line, Some(8));
    let real = find(&p, &["attribute 'variability' is not defined for <Real>"]);
    assert_eq!(real.line, Some(47));
    // An attribute at the very start of its line, as some generators write them.
    let p = problems(&[(
        "  author=\"ckcm project\"\n",
        "  author=\"ckcm project\"\ncopyrite=\"2026\"\n",
    )]);
    assert_eq!(find(&p, &["attribute 'copyrite'"]).line, Some(8));
    // What the schema defines passes, `copyright` and `license` among it.
    let p = problems(&[(
        "  author=\"ckcm project\"\n",
        "  author=\"ckcm project\"\n  copyright=\"2026\" license=\"MIT\"\n",
    )]);
    assert_eq!(p, vec![]);
}

/// Text where the schema allows elements only is a problem at the text's line, once per
/// element; whitespace, comments and a `<Tool>`'s content are free.
#[test]
fn text_where_elements_belong() {
    let p = problems(&[
        (
            "    <!-- index 1 -->\n",
            "    <!-- index 1 -->\n    forces:\n    <![CDATA[more]]>\n",
        ),
        (
            "<Real declaredType=\"Force\" start=\"0\"/>",
            "<Real declaredType=\"Force\" start=\"0\">&amp;</Real>",
        ),
        (
            "  <ModelVariables>\n",
            "  <VendorAnnotations><Tool name=\"t\"><Any>free</Any></Tool></VendorAnnotations>\n  <ModelVariables>\n",
        ),
    ]);
    assert_eq!(p.len(), 2, "{p:#?}");
    let list = find(&p, &["ModelVariables: text is not allowed here"]);
    assert_eq!(list.line, Some(46));
    let real = find(&p, &["Real: text is not allowed here"]);
    assert_eq!(real.line, Some(49));
}

/// Names follow the description's naming convention (the fixture's is `structured`).
#[test]
fn names_follow_the_naming_convention() {
    let p = problems(&[(
        "name=\"x[1]\" valueReference=\"11\"",
        "name=\"x[01].1\" valueReference=\"11\"",
    )]);
    let bad = find(
        &p,
        &[
            "ScalarVariable 'x[01].1'",
            "not a structured name",
            "a name cannot start with '1' at character 7",
        ],
    );
    assert_eq!(bad.line, Some(69));
    assert_eq!(p.len(), 1, "{p:#?}");
    let p = problems(&[
        (
            "variableNamingConvention=\"structured\"",
            "variableNamingConvention=\"flat\"",
        ),
        (
            "name=\"x[1]\" valueReference=\"11\"",
            "name=\"x\\[01].1 &#10;\" valueReference=\"11\"",
        ),
    ]);
    // The label writes the line feed out and doubles the backslash, so the two read apart.
    find(
        &p,
        &[
            "ScalarVariable 'x\\\\[01].1 \\u{a}'",
            "name holds a line feed at character 10, which flat names may not",
        ],
    );
    assert_eq!(p.len(), 1, "{p:#?}");
}
