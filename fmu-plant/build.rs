//! Generates the variable and enumeration tables from the model description named in
//! `[package.metadata.fmu]`, the single source of truth for names, value references,
//! causalities, enumeration items and start values.

fn main() {
    fmu_build::generate();
}
