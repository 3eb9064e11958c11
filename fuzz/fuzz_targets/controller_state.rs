//! `common/state.rs` on the controller model.
#![no_main]

use std::sync::OnceLock;

#[path = "../common/state.rs"]
mod state;

static BASELINE: OnceLock<Vec<u8>> = OnceLock::new();

libfuzzer_sys::fuzz_target!(
    |bytes: &[u8]| state::run::<hlcs_controller::HlcsController>(bytes, &BASELINE)
);
