//! Any text as a sweep file beside the shipped scenarios (so `base = "line-hlcs.toml"` and
//! the other shipped files resolve): either a sweep whose cases keep the validation's
//! promises, or an error naming the file, with a line inside the text. A panic or a hang is
//! a finding.
#![no_main]

#[path = "../common/file_error.rs"]
mod file_error;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use orchestrator::sweep::spec::MAX_CASES;
use orchestrator::sweep::{Combine, SweepSpec};

fuzz_target!(|bytes: &[u8]| {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    // Paths to devices would only test the file system, slowly: `/dev/zero` reads up to
    // the 64 MiB bound for every such input.
    if text.contains("/dev") || text.contains("/proc") || text.contains("/sys") {
        return;
    }
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/fuzz-sweep.toml");
    match SweepSpec::parse(text, &file) {
        Ok(spec) => {
            assert!(!spec.cases.is_empty() && spec.cases.len() <= MAX_CASES);
            assert!(spec.trials.is_none_or(|t| t >= 1));
            assert!(spec.threshold.is_finite() && spec.threshold > 0.0);
            for case in &spec.cases {
                assert_eq!(case.len(), spec.axes.len());
                for (axis, &v) in spec.axes.iter().zip(case) {
                    assert!(v < axis.values.len() && v < axis.labels.len());
                }
            }
            if spec.combine == Combine::Zip {
                assert!(spec.axes.iter().all(|a| a.values.len() == spec.cases.len()));
            }
            let names: std::collections::BTreeSet<&str> =
                spec.axes.iter().map(|a| a.name.as_str()).collect();
            assert_eq!(names.len(), spec.axes.len(), "two axes of one name");
            let _ = spec.case_labels(spec.cases.len() - 1);
        }
        Err(e) => file_error::check(text, &file, &e.file, e.line, &e.message, &e.to_string()),
    }
});
