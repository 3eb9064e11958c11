//! `common/calls.rs` on the packaged plant FMU (`target/fmu/CkcmPlant.fmu`, or `$CKCM_FMU_DIR`).
#![no_main]

#[path = "../common/calls.rs"]
mod calls;

thread_local! {
    static FMU: fmi2_import::Fmu = calls::open("CkcmPlant.fmu");
}

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| FMU.with(|fmu| calls::run(fmu, bytes)));
