//! `common/params.rs` on the plant model.
#![no_main]

#[path = "../common/params.rs"]
mod params;

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| params::run::<ckcm_plant::CkcmPlant>(bytes));
