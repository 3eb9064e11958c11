//! `KeptFmus` hands out the FMU it opened for a slot until that is no longer safe.

#[path = "support/mod.rs"]
mod import_support;

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use fmi2_import::{Fmu, KeptFmus};

fn dir_of(fmu: &Fmu) -> PathBuf {
    fmu.unpacked_dir().to_path_buf()
}

/// Two copies of the dummy FMU in their own folders (`a/` and `b/`).
fn two(root: &Path) -> (PathBuf, PathBuf) {
    let (a, b) = (root.join("a"), root.join("b"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    (import_support::dummy_fmu(&a), import_support::dummy_fmu(&b))
}

#[test]
fn a_slot_keeps_its_fmu_until_its_file_changes_or_it_is_cleared() {
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = two(tmp.path());
    let mut kept = KeptFmus::default();
    let first = [
        dir_of(&kept.open(0, &a).unwrap()),
        dir_of(&kept.open(1, &b).unwrap()),
    ];
    assert_eq!(dir_of(&kept.open(0, &a).unwrap()), first[0], "reused");
    // Another file in slot 0 is opened; slot 1 keeps its FMU.
    let other = dir_of(&kept.open(0, &b).unwrap());
    assert_ne!(other, first[1]);
    assert_eq!(dir_of(&kept.open(1, &b).unwrap()), first[1]);
    // A replaced file is opened again.
    let file = std::fs::File::options().append(true).open(&b).unwrap();
    file.set_modified(SystemTime::now() + Duration::from_secs(5))
        .unwrap();
    drop(file);
    assert_ne!(dir_of(&kept.open(1, &b).unwrap()), first[1], "file changed");
    // After clear, everything is opened again.
    let before = dir_of(&kept.open(0, &a).unwrap());
    assert_eq!(dir_of(&kept.open(0, &a).unwrap()), before);
    kept.clear();
    assert_ne!(dir_of(&kept.open(0, &a).unwrap()), before, "cleared");
    // A kept FMU still instantiates.
    let fmu = kept.open(0, &a).unwrap();
    fmu.instantiate("again", false).unwrap();
}

#[test]
fn an_fmu_instantiated_only_once_per_process_is_opened_every_time() {
    let tmp = tempfile::tempdir().unwrap();
    let xml = import_support::MODEL_DESCRIPTION.replacen(
        "<CoSimulation",
        "<CoSimulation canBeInstantiatedOnlyOncePerProcess=\"true\"",
        1,
    );
    assert_ne!(xml, import_support::MODEL_DESCRIPTION);
    let once = import_support::dummy_fmu_with(tmp.path(), &xml);
    let mut kept = KeptFmus::default();
    let first = dir_of(&kept.open(0, &once).unwrap());
    assert_ne!(dir_of(&kept.open(0, &once).unwrap()), first);
}

#[test]
fn a_file_that_cannot_be_opened_is_an_error_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let missing = tmp.path().join("missing.fmu");
    let mut kept = KeptFmus::default();
    let err = kept.open(2, &missing).unwrap_err().to_string();
    assert!(err.contains("missing.fmu"), "{err}");
}
