//! Helpers shared by the CLI tests: the `orchestrator` binary, the built CKCM FMUs, the
//! foreign test FMU packaged on demand, and rewritten archives for bad-input cases.

// Each test binary includes this module and uses a different subset of it.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::SystemTime;

use orchestrator::output::{Recording, read_recording_csv};

/// The closed loop of the two CKCM FMUs as scenario text: the plant's lengths and rates to
/// the controller, its force to the plant, and the iteration memory channel (a
/// `[memory.update]` table may follow it).
pub const CLOSED_LOOP: &str = r#"
[[connection]]
from = "plant.length"
to = "controller.length"

[[connection]]
from = "plant.velocity"
to = "controller.velocity"

[[connection]]
from = "controller.force"
to = "plant.force"

[[memory]]
from = "controller.memory_next"
to = "controller.memory"
"#;

/// Absolute path of the packaged FMU `name` (checked fresh), as written in a scenario.
pub fn fmu_path_text(name: &str) -> String {
    std::fs::canonicalize(built_fmu(name))
        .unwrap()
        .display()
        .to_string()
}

/// The workspace root (the orchestrator crate's parent).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("orchestrator lives inside the workspace")
        .to_path_buf()
}

/// The bytes of `name` inside the archive `fmu`.
pub fn archive_entry(fmu: &Path, name: &str) -> Vec<u8> {
    let file = std::fs::File::open(fmu).unwrap_or_else(|e| panic!("{}: {e}", fmu.display()));
    let mut archive = zip::ZipArchive::new(file).unwrap();
    let mut entry = archive
        .by_name(name)
        .unwrap_or_else(|e| panic!("{}: no {name} inside: {e}", fmu.display()));
    let mut bytes = Vec::new();
    entry.read_to_end(&mut bytes).unwrap();
    bytes
}

/// A command running the `orchestrator` binary built for these tests.
pub fn orchestrator() -> assert_cmd::Command {
    assert_cmd::Command::new(env!("CARGO_BIN_EXE_orchestrator"))
}

/// What the packaged FMUs are built from (relative to the workspace root), as
/// `tests/fmu-sources.txt` lists them: an FMU older than any of these was packaged from
/// other sources and would test old code.
pub fn fmu_sources() -> Vec<String> {
    let path = workspace_root().join("tests/fmu-sources.txt");
    std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(str::to_owned)
        .collect()
}

/// The newest modification time of the files under `paths` (relative to the workspace
/// root; missing paths are skipped), with the file.
pub fn newest_source(paths: &[&str]) -> Option<(SystemTime, PathBuf)> {
    let mut newest: Option<(SystemTime, PathBuf)> = None;
    let mut stack: Vec<PathBuf> = paths.iter().map(|p| workspace_root().join(p)).collect();
    while let Some(path) = stack.pop() {
        let Ok(meta) = std::fs::metadata(&path) else {
            continue;
        };
        if meta.is_dir() {
            for entry in std::fs::read_dir(&path).unwrap() {
                stack.push(entry.unwrap().path());
            }
        } else if let Ok(modified) = meta.modified() {
            if newest.as_ref().is_none_or(|(t, _)| modified > *t) {
                newest = Some((modified, path));
            }
        }
    }
    newest
}

/// Fails loudly when `artifact` is older than a file it is built from, naming both and the
/// command that rebuilds it: a stale FMU or binary would test old code and pass.
pub fn assert_fresh(artifact: &Path, sources: &[&str], rebuild: &str) {
    let built = std::fs::metadata(artifact)
        .and_then(|m| m.modified())
        .unwrap_or_else(|e| panic!("{}: {e}", artifact.display()));
    if let Some((modified, source)) = newest_source(sources) {
        assert!(
            built >= modified,
            "{} is older than {}: it was built from other sources; run `{rebuild}`",
            artifact.display(),
            source.display()
        );
    }
}

/// `$CKCM_FMU_DIR/<name>.fmu`, by default `<workspace>/target/fmu/<name>.fmu`, which
/// `cargo xtask fmu` builds; it must be newer than its sources.
pub fn built_fmu(name: &str) -> PathBuf {
    let dir = std::env::var_os("CKCM_FMU_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target/fmu"));
    let path = dir.join(format!("{name}.fmu"));
    assert!(
        path.is_file(),
        "{} is missing: run `cargo xtask fmu` first (or point CKCM_FMU_DIR at the FMUs)",
        path.display()
    );
    let sources = fmu_sources();
    let sources: Vec<&str> = sources.iter().map(String::as_str).collect();
    assert_fresh(&path, &sources, "cargo xtask fmu");
    path
}

/// The model description of the foreign test FMU.
pub fn foreign_xml() -> String {
    let path = workspace_root().join("tests/fixtures/foreign-fmu/modelDescription.xml");
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The foreign FMU's shared library of this test profile, (re)built with cargo first:
/// `cargo test -p orchestrator` builds no other workspace member, and a library left over
/// from an older checkout would silently test old code. When the library is current the
/// build is a no-op.
pub fn foreign_cdylib() -> &'static Path {
    static LIB: OnceLock<PathBuf> = OnceLock::new();
    LIB.get_or_init(|| {
        // The test executable is target/<profile>/deps/<name>; cdylibs land in target/<profile>.
        let exe = std::env::current_exe().expect("path of the test executable");
        let profile_dir = exe
            .parent()
            .and_then(Path::parent)
            .expect("test executable inside target/<profile>/deps");
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.current_dir(workspace_root())
            .args(["build", "--quiet", "-p", "foreign-fmu"]);
        if profile_dir.file_name().is_some_and(|n| n == "release") {
            cmd.arg("--release");
        }
        let status = cmd.status().expect("cannot run cargo");
        assert!(status.success(), "cargo build -p foreign-fmu failed");
        let lib = profile_dir.join(format!(
            "{}foreign_fmu.{}",
            std::env::consts::DLL_PREFIX,
            std::env::consts::DLL_EXTENSION
        ));
        assert!(lib.is_file(), "{} was not built", lib.display());
        lib
    })
}

/// Packages the foreign FMU with the given model description into `dir/<file>`.
pub fn foreign_fmu_with(dir: &Path, file: &str, xml: &str) -> PathBuf {
    let path = dir.join(file);
    fmu_build::write_fmu(&path, xml, Some(foreign_cdylib()), &[])
        .unwrap_or_else(|e| panic!("cannot write {}: {e}", path.display()));
    path
}

/// The foreign FMU as built, packaged into `dir/DampedOscillator.fmu`.
pub fn foreign_fmu(dir: &Path) -> PathBuf {
    foreign_fmu_with(dir, "DampedOscillator.fmu", &foreign_xml())
}

/// Copies the archive `src` to `dst`, passing every entry through `edit(name, bytes)`;
/// `None` drops the entry.
pub fn repackage(src: &Path, dst: &Path, edit: impl Fn(&str, Vec<u8>) -> Option<Vec<u8>>) {
    let mut archive = zip::ZipArchive::new(std::fs::File::open(src).unwrap()).unwrap();
    let mut out = zip::ZipWriter::new(std::fs::File::create(dst).unwrap());
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .unix_permissions(0o755);
    for i in 0..archive.len() {
        let mut entry = archive.by_index(i).unwrap();
        if entry.is_dir() {
            continue;
        }
        let name = entry.name().unwrap().into_owned();
        let mut bytes = Vec::new();
        entry.read_to_end(&mut bytes).unwrap();
        if let Some(bytes) = edit(&name, bytes) {
            out.start_file(name, options).unwrap();
            out.write_all(&bytes).unwrap();
        }
    }
    out.finish().unwrap();
}

/// Reads a recording CSV (`simulate`'s output, or a campaign's trial).
pub fn read_csv(path: &Path) -> Recording {
    read_recording_csv(path).unwrap_or_else(|e| panic!("{e}"))
}

/// The column `name` of `rec`, which must exist.
pub fn column<'a>(rec: &'a Recording, name: &str) -> &'a [f64] {
    rec.column(name)
        .unwrap_or_else(|| panic!("no column {name} in {:?}", rec.names))
}

/// Every file under `dir`, relative path → bytes: two result folders compare as wholes.
pub fn tree(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                );
            }
        }
    }
    out
}

/// The number that follows the first `marker` in a message, up to the next space (a time
/// such as "at t = 0.1 s").
pub fn number_after(text: &str, marker: &str) -> f64 {
    let rest = text
        .split_once(marker)
        .unwrap_or_else(|| panic!("no {marker:?} in {text}"))
        .1;
    let word = rest.split(' ').next().unwrap_or_default();
    word.parse()
        .unwrap_or_else(|e| panic!("{word:?} after {marker:?} in {text}: {e}"))
}

/// `orchestrator run SCENARIO --out OUT ARGS…`, run to its end.
pub fn run_scenario(scenario: &Path, out: &Path, args: &[&str]) -> std::process::Output {
    orchestrator()
        .arg("run")
        .arg(scenario)
        .arg("--out")
        .arg(out)
        .args(args)
        .output()
        .unwrap()
}
