//! Any text as a scenario file against the two FMUs' model descriptions (and the foreign
//! fixture's): either a scenario that keeps the validation's promises, or an error naming the
//! file, with a line inside the text. A panic or a hang is a finding.
#![no_main]

#[path = "../common/file_error.rs"]
mod file_error;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use fmi2_md::ModelDescription;
use libfuzzer_sys::fuzz_target;
use orchestrator::scenario::Scenario;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn models() -> &'static [(&'static str, ModelDescription); 3] {
    static MODELS: OnceLock<[(&str, ModelDescription); 3]> = OnceLock::new();
    MODELS.get_or_init(|| {
        let md = |p: &str| ModelDescription::from_file(root().join(p)).expect("model description");
        [
            ("Plant", md("modelDescription/CkcmPlant.xml")),
            ("Controller", md("modelDescription/HlcsController.xml")),
            (
                "Oscillator",
                md("tests/fixtures/foreign-fmu/modelDescription.xml"),
            ),
        ]
    })
}

fn describe(fmu: &Path) -> Result<ModelDescription, String> {
    let name = fmu.file_name().unwrap_or_default().to_string_lossy();
    models()
        .iter()
        .find(|(key, _)| name.contains(key))
        .map(|(_, md)| md.clone())
        .ok_or_else(|| format!("no such FMU {name}"))
}

fuzz_target!(|bytes: &[u8]| {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    let file = Path::new("fuzz.toml");
    match Scenario::parse(text, file, describe) {
        Ok(s) => {
            assert!(s.step_size.is_finite() && s.step_size > 0.0);
            assert!(s.stop_time.is_finite() && s.stop_time > s.start_time);
            assert!(s.steps >= 1 && s.trials >= 1 && s.record.interval >= 1);
        }
        Err(e) => file_error::check(text, &file, &e.file, e.line, &e.message, &e.to_string()),
    }
});
