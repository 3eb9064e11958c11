//! Any bytes as a model description: parsed, or refused with an `MdError`; whatever parses
//! also validates and generates code (as the build scripts would). A panic or a hang is a finding.
#![no_main]

use fmi2_md::ModelDescription;
use fmi2_md::codegen::codegen_rust;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    if let Ok(md) = ModelDescription::parse(text) {
        let _ = md.validate();
        let _ = codegen_rust(&md);
    }
});
