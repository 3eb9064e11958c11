//! `common/params.rs` on the controller model.
#![no_main]

#[path = "../common/params.rs"]
mod params;

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| params::run::<hlcs_controller::HlcsController>(bytes));
