//! Generates the variable table from `modelDescription/HlcsController.xml`, the single source of
//! truth for names, value references, causalities and start values.

fn main() {
    let xml = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../modelDescription/HlcsController.xml"
    );
    println!("cargo::rerun-if-changed={xml}");
    let md = fmi2::md::ModelDescription::from_file(xml).unwrap_or_else(|e| panic!("{e}"));
    let problems = md.validate();
    assert!(problems.is_empty(), "{xml} has problems:\n{problems:#?}");
    let out = std::path::Path::new(&std::env::var("OUT_DIR").unwrap()).join("model_description.rs");
    std::fs::write(out, fmi2::md::codegen::codegen_rust(&md)).unwrap();
}
