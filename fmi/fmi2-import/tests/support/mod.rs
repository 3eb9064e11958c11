//! Builds the C test FMU (`fixtures/dummy_fmu.c`) into a .fmu archive, the way a
//! test packages any cdylib with `fmu_build::write_fmu`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The description the dummy FMU implements.
pub const MODEL_DESCRIPTION: &str = include_str!("../../../fmi2-md/tests/fixtures/valid.xml");

/// Compiles the dummy FMU's shared library once per test binary (needs a C compiler,
/// `$CC` or `cc`) and returns its path.
pub fn dummy_library() -> &'static Path {
    static LIB: OnceLock<PathBuf> = OnceLock::new();
    LIB.get_or_init(|| {
        let out = Path::new(env!("CARGO_TARGET_TMPDIR"))
            .join(format!("fmi2-dummy-{}.so", std::process::id()));
        compile(&out, &[]);
        out
    })
}

/// The dummy FMU's shared library compiled into `out` with the extra compiler arguments
/// `defines` (e.g. `-DDUMMY_VERSION="1.0"`).
pub fn compile(out: &Path, defines: &[&str]) {
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/dummy_fmu.c");
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let status = Command::new(&cc)
        .args(["-shared", "-fPIC", "-fvisibility=hidden", "-Wall", "-o"])
        .arg(out)
        .args(defines)
        .arg(&source)
        .arg("-lm")
        .status()
        .unwrap_or_else(|e| panic!("cannot run the C compiler '{cc}': {e}"));
    assert!(status.success(), "compiling {} failed", source.display());
}

/// Writes `dir/MiniPlatform.fmu` with the dummy binary and the given description.
pub fn dummy_fmu_with(dir: &Path, model_description: &str) -> PathBuf {
    let path = dir.join("MiniPlatform.fmu");
    fmu_build::write_fmu(
        &path,
        model_description,
        Some(dummy_library()),
        &[("resources/table.csv", b"t,x\n0,1\n")],
    )
    .unwrap();
    path
}

/// Writes `dir/MiniPlatform.fmu` with the dummy binary and the matching description.
pub fn dummy_fmu(dir: &Path) -> PathBuf {
    dummy_fmu_with(dir, MODEL_DESCRIPTION)
}
