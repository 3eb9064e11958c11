//! Compiles the C logger shim of the import side (only with the `import` feature:
//! FMU crates, which use only the export side, need no C compiler).

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-changed=csrc/logger.c");
    if std::env::var_os("CARGO_FEATURE_IMPORT").is_some() {
        cc::Build::new()
            .file("csrc/logger.c")
            .warnings(true)
            .extra_warnings(true)
            .compile("fmi2_import_logger");
    }
}
