//! The generated Rust for the fixture compiles (it is `include!`d below, as an FMU
//! crate's build output would be) and stays identical to what `codegen_rust` emits now.
//! After an intended change of the generator, refresh the golden file with
//! `FMI2_BLESS=1 cargo test -p fmi2-md --test codegen`.

use fmi2_md::ModelDescription;
use fmi2_md::codegen::codegen_rust;
use fmi2_md::{Causality, VarType, Variability};

mod generated {
    include!("fixtures/valid_generated.rs");
}

const GOLDEN: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/fixtures/valid_generated.rs"
);

#[test]
fn golden_file_is_current() {
    let md = ModelDescription::parse(include_str!("fixtures/valid.xml")).unwrap();
    let fresh = codegen_rust(&md);
    if std::env::var_os("FMI2_BLESS").is_some() {
        std::fs::write(GOLDEN, &fresh).unwrap();
    }
    assert_eq!(
        std::fs::read_to_string(GOLDEN).unwrap(),
        fresh,
        "rerun with FMI2_BLESS=1 after an intended change"
    );
}

#[test]
fn generated_constants_match_the_description() {
    assert_eq!(generated::GUID, "{6f1c3a52-8d0e-4b7a-9e21-3c5d7a1b2f90}");
    assert_eq!(generated::MODEL_IDENTIFIER, "MiniPlatform");
    const { assert!(generated::CAN_HANDLE_VARIABLE_STEP) };
    assert_eq!(generated::vr::FORCE_1, 1);
    assert_eq!(generated::vr::FORCE_6, 6);
    assert_eq!(generated::vr::X_4, 14);
    assert_eq!(generated::vr::TOTAL_MASS, 25);

    assert_eq!(generated::enums::TRAJECTORY_HOLD, 1);
    assert_eq!(generated::enums::TRAJECTORY_LINE, 2);
    assert_eq!(generated::enums::TRAJECTORY_CIRCLE, 3);
    assert_eq!(
        generated::enums::TRAJECTORY_ITEMS,
        "1 hold, 2 line, 3 circle"
    );

    assert_eq!(generated::VARIABLES.len(), 18);
    let x4 = generated::VARIABLES
        .iter()
        .find(|v| v.name == "x[4]")
        .unwrap();
    assert_eq!(
        (
            x4.value_reference,
            x4.var_type,
            x4.causality,
            x4.variability
        ),
        (
            14,
            VarType::Real,
            Causality::Output,
            Variability::Continuous
        )
    );
    let traj = generated::VARIABLES
        .iter()
        .find(|v| v.name == "trajectory")
        .unwrap();
    assert_eq!(
        (traj.var_type, traj.causality, traj.variability),
        (
            VarType::Enumeration,
            Causality::Parameter,
            Variability::Fixed
        )
    );

    assert_eq!(
        generated::START,
        &[
            (1, VarType::Real, 0.0),
            (2, VarType::Real, 0.0),
            (3, VarType::Real, 0.0),
            (4, VarType::Real, 0.0),
            (5, VarType::Real, 0.0),
            (6, VarType::Real, 0.0),
            (21, VarType::Real, 4.92),
            (22, VarType::Enumeration, 2.0),
            (23, VarType::Boolean, 1.0),
            (24, VarType::Integer, 3.0),
        ]
    );
}
