//! `remove_extraction_dirs`, as a signal handler calls it before exiting: every extraction
//! folder of the process goes, and none can be made after it. A test binary of its own,
//! since the call leaves FMU opening blocked for the rest of the process.

use std::path::PathBuf;
use std::sync::mpsc;
use std::time::Duration;

use fmi2_import::{EXTRACTION_PREFIX, Fmu, remove_extraction_dirs};
use fmu_build::write_fmu;

const VALID: &str = include_str!("../../fmi2-md/tests/fixtures/valid.xml");

/// This process's extraction folders in the temp directory.
fn ours() -> Vec<PathBuf> {
    let prefix = format!("{EXTRACTION_PREFIX}{}-", std::process::id());
    std::fs::read_dir(std::env::temp_dir())
        .unwrap()
        .filter_map(Result::ok)
        .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
        .map(|e| e.path())
        .collect()
}

#[test]
fn no_extraction_folder_is_made_after_the_handler_removed_them() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = dir.path().join("Model.fmu");
    // No binary: opening unpacks it into a folder, then fails to load, dropping the folder.
    write_fmu(&fmu, VALID, None, &[]).unwrap();
    assert!(Fmu::open(&fmu).is_err());
    assert!(ours().is_empty(), "{:?}", ours());

    remove_extraction_dirs();
    // A thread that opens an FMU now must not make a folder: the process is exiting.
    let (done, finished) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = Fmu::open(&fmu);
        let _ = done.send(());
    });
    assert!(
        finished.recv_timeout(Duration::from_millis(300)).is_err(),
        "an FMU was opened after the extraction folders were removed"
    );
    assert!(ours().is_empty(), "{:?}", ours());
}
