//! The win64 build: the FMUs' DLLs (PE import and export tables), and the cross-built
//! `orchestrator.exe` run under Wine against the Linux build of the same code.
//!
//! Needs what `cargo xtask test` prepares: the packaged FMUs (with `binaries/win64`),
//! `target/wine/bin/orchestrator.exe` beside the test-only `bcryptprimitives.dll`
//! stand-in (`CKCM_WINE_ORCHESTRATOR` overrides the path) and the Wine prefix
//! `target/wine/prefix` (`WINEPREFIX`). A missing piece fails the test with the command
//! that makes it; nothing is skipped.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::{archive_entry, built_fmu, orchestrator, repackage, workspace_root};
use object::{Object, ObjectSymbol};

/// The FMUs: model identifier and name of the Linux binary inside the archive.
const FMUS: [&str; 2] = ["CkcmPlant", "HlcsController"];

/// DLLs that every 64-bit Windows (10 and 11, which Rust supports) has in System32, or
/// that the loader resolves itself (the `api-ms-win-*` API sets). MinGW's runtime DLLs
/// (`libgcc_s_seh-1.dll`, `libwinpthread-1.dll`, `libstdc++-6.dll`) are not among them:
/// `.cargo/config.toml` links them statically.
const SYSTEM_DLLS: [&str; 9] = [
    "kernel32.dll",
    "ntdll.dll",
    "msvcrt.dll",
    "advapi32.dll",
    "userenv.dll",
    "ws2_32.dll",
    "bcrypt.dll",
    "bcryptprimitives.dll",
    "api-ms-win-core-synch-l1-2-0.dll",
];

/// Values of the Wine and Linux runs agree to this, relative to their scale (see
/// [`assert_csv_close`]).
const REL_TOL: f64 = 1e-12;

#[test]
fn win64_dlls_import_only_system_dlls_and_export_every_fmi_function() {
    for id in FMUS {
        let fmu = built_fmu(id);
        // Both platforms side by side.
        assert!(!archive_entry(&fmu, &format!("binaries/linux64/{id}.so")).is_empty());
        let dll_name = format!("binaries/win64/{id}.dll");
        let dll = archive_entry(&fmu, &dll_name);
        let pe = object::read::pe::PeFile64::parse(dll.as_slice())
            .unwrap_or_else(|e| panic!("{dll_name} in {}: not a PE32+ file: {e}", fmu.display()));
        assert_eq!(
            pe.architecture(),
            object::Architecture::X86_64,
            "{dll_name}"
        );

        let imports: Vec<object::Import> = pe
            .imports()
            .and_then(Iterator::collect)
            .unwrap_or_else(|e| panic!("{dll_name}: unreadable import table: {e}"));
        assert!(!imports.is_empty(), "{dll_name} imports nothing?");
        let mut libraries: Vec<String> = imports
            .iter()
            .map(|i| String::from_utf8_lossy(i.library()).to_ascii_lowercase())
            .collect();
        libraries.sort();
        libraries.dedup();
        let foreign: Vec<&String> = libraries
            .iter()
            .filter(|l| !SYSTEM_DLLS.contains(&l.as_str()))
            .collect();
        assert!(
            foreign.is_empty(),
            "{dll_name} in {} imports non-system DLLs {foreign:?} (all: {libraries:?})",
            fmu.display()
        );
        assert!(
            libraries.iter().any(|l| l == "kernel32.dll"),
            "{libraries:?}"
        );

        let exports: Vec<object::Export> = pe
            .exports()
            .and_then(Iterator::collect)
            .unwrap_or_else(|e| panic!("{dll_name}: unreadable export table: {e}"));
        // Exported by name: an ordinal-only export is invisible to GetProcAddress(name).
        let exports: Vec<String> = exports
            .iter()
            .filter_map(|e| match e.name() {
                object::read::NameOrOrdinal::Name(name) => {
                    Some(String::from_utf8_lossy(name).into_owned())
                }
                object::read::NameOrOrdinal::Ordinal(_) => None,
            })
            .collect();
        assert_eq!(fmi2_import::SYMBOLS.len(), 34);
        for symbol in fmi2_import::SYMBOLS {
            assert!(
                exports.iter().any(|e| e == symbol),
                "{dll_name} in {} does not export {symbol} by name",
                fmu.display()
            );
        }
        // An export-table check that can fail: the dynamic symbol table of the Linux
        // build names the same functions, so both binaries come from the same code.
        let so = archive_entry(&fmu, &format!("binaries/linux64/{id}.so"));
        let elf = object::File::parse(so.as_slice()).unwrap();
        let elf_exports: Vec<String> = elf
            .dynamic_symbols()
            .filter(|s| s.is_definition() && s.is_global())
            .filter_map(|s| s.name().ok().map(str::to_owned))
            .filter(|n| n.starts_with("fmi2"))
            .collect();
        let mut win_fmi: Vec<&String> = exports.iter().filter(|e| e.starts_with("fmi2")).collect();
        win_fmi.sort();
        let mut linux_fmi: Vec<&String> = elf_exports.iter().collect();
        linux_fmi.sort();
        assert_eq!(
            win_fmi, linux_fmi,
            "{id}: win64 and linux64 export different fmi2 functions"
        );
    }
}

/// A DLL's bytes depend on its code alone, not on when it was linked: the PE headers'
/// link time would make every relink of the same code another `.fmu`, and `run --resume`
/// refuses a campaign whose FMU bytes changed (`.cargo/config.toml`,
/// `--no-insert-timestamp`). Both places ld writes it are checked: the COFF header and the
/// export directory.
#[test]
fn win64_dlls_carry_no_link_time() {
    use object::LittleEndian as LE;
    for id in FMUS {
        let fmu = built_fmu(id);
        let dll_name = format!("binaries/win64/{id}.dll");
        let dll = archive_entry(&fmu, &dll_name);
        let pe = object::read::pe::PeFile64::parse(dll.as_slice())
            .unwrap_or_else(|e| panic!("{dll_name} in {}: not a PE32+ file: {e}", fmu.display()));
        let header = pe.nt_headers().file_header.time_date_stamp.get(LE);
        assert_eq!(header, 0, "{dll_name}: COFF header time stamp {header:#x}");
        let exports = pe
            .export_table()
            .unwrap_or_else(|e| panic!("{dll_name}: unreadable export table: {e}"))
            .unwrap_or_else(|| panic!("{dll_name}: no export table"));
        let export = exports.directory().time_date_stamp.get(LE);
        assert_eq!(
            export, 0,
            "{dll_name}: export directory time stamp {export:#x}"
        );
    }
}

/// `orchestrator.exe` as `cargo xtask test` prepared it.
fn wine_orchestrator() -> PathBuf {
    let exe = std::env::var_os("CKCM_WINE_ORCHESTRATOR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target/wine/bin/orchestrator.exe"));
    assert!(
        exe.is_file() && exe.with_file_name("bcryptprimitives.dll").is_file(),
        "{} (with bcryptprimitives.dll beside it) is missing: run `cargo xtask test`, \
         which cross-builds it and prepares Wine",
        exe.display()
    );
    exe
}

/// `wine orchestrator.exe ARGS` in the test prefix, quiet.
fn wine(args: &[&str]) -> Output {
    let prefix = std::env::var_os("WINEPREFIX")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target/wine/prefix"));
    assert!(
        prefix.join("system.reg").is_file(),
        "no Wine prefix at {}: run `cargo xtask test`, which creates it",
        prefix.display()
    );
    Command::new("wine")
        .arg(wine_orchestrator())
        .args(args)
        .env("WINEPREFIX", &prefix)
        .env("WINEDEBUG", "-all")
        .env("WINEDLLOVERRIDES", "mscoree,mshtml=")
        .output()
        .expect("cannot start wine: run `cargo xtask test`, which installs it")
}

/// The Windows name of a Linux path under Wine (its `Z:` drive is `/`).
fn win_path(path: &Path) -> String {
    let absolute = std::path::absolute(path).unwrap();
    format!("Z:{}", absolute.display()).replace('/', "\\")
}

/// Fails with both output streams unless the run succeeded.
fn assert_success(out: &Output, what: &str) {
    assert!(
        out.status.success(),
        "{what} failed ({}):\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Largest differences found between two CSV files.
#[derive(Debug, Default, Clone, Copy)]
struct Differences {
    /// Largest |a − b| / scale (see [`assert_csv_close`]).
    relative: f64,
    /// Largest |a − b| (SI units).
    absolute: f64,
    /// Values that are not bit-identical.
    count: usize,
}

impl Differences {
    fn merge(self, other: Differences) -> Differences {
        Differences {
            relative: self.relative.max(other.relative),
            absolute: self.absolute.max(other.absolute),
            count: self.count + other.count,
        }
    }
}

/// Two CSV files with the same header, the same number of rows and, field by field,
/// either the same text or numbers with |a − b| ≤ `REL_TOL` · scale, where scale is the
/// largest of |a|, |b|, the largest magnitude in that column, and 1 (SI unit).
///
/// Why not |a| alone: the two builds use different C math libraries (glibc against
/// mingw-w64's msvcrt), whose sin, cos, expm1 or exp may round differently by an ulp. The
/// leg lengths then differ by an ulp or two of 0.7 m (~2e-16 m); a leg error e = l_d − l of
/// 1e-5 m computed from them differs by 1e-11 of itself, a force by Kp·2e-16 m ≈ 1e-11 N,
/// and an orientation that is round-off around zero (the line has none) by 100 %, while
/// every quantity agrees to ~1e-12 of its own scale.
fn assert_csv_close(linux: &Path, windows: &Path) -> Differences {
    let read = |p: &Path| -> Vec<Vec<String>> {
        csv::ReaderBuilder::new()
            .has_headers(false)
            .from_path(p)
            .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
            .records()
            .map(|r| r.unwrap().iter().map(str::to_owned).collect())
            .collect()
    };
    let (a, b) = (read(linux), read(windows));
    assert_eq!(
        a.first(),
        b.first(),
        "headers differ: {}",
        windows.display()
    );
    assert_eq!(a.len(), b.len(), "row counts differ: {}", windows.display());
    assert!(a.len() > 1, "{} has no data rows", linux.display());
    let scale: Vec<f64> = (0..a[0].len())
        .map(|c| {
            a[1..]
                .iter()
                .filter_map(|row| row.get(c)?.parse::<f64>().ok())
                .fold(1.0_f64, |m, v| m.max(v.abs()))
        })
        .collect();
    let mut found = Differences::default();
    for (n, (ra, rb)) in a.iter().zip(&b).enumerate().skip(1) {
        assert_eq!(ra.len(), rb.len(), "{} row {n}", windows.display());
        for (c, (fa, fb)) in ra.iter().zip(rb).enumerate() {
            if fa == fb {
                continue;
            }
            let column = &a[0][c];
            let (Ok(x), Ok(y)) = (fa.parse::<f64>(), fb.parse::<f64>()) else {
                panic!(
                    "{} row {n} column {column}: {fa:?} against {fb:?}",
                    windows.display()
                );
            };
            let diff = (x - y).abs();
            let rel = diff / x.abs().max(y.abs()).max(scale[c]);
            assert!(
                rel <= REL_TOL,
                "{} row {n} column {column}: Linux {x:e}, Windows {y:e} (difference {diff:e}, \
                 {rel:e} of the scale {:e})",
                windows.display(),
                scale[c]
            );
            found.count += 1;
            found.absolute = found.absolute.max(diff);
            found.relative = found.relative.max(rel);
        }
    }
    found
}

/// A 3-trial HLCS campaign on `trajectory` with every sample recorded, run by the Linux
/// build and by `orchestrator.exe` under Wine from the same scenario file (FMUs beside
/// it, so Windows resolves the relative paths itself): summary.csv, memory.csv and every
/// trial CSV agree to `REL_TOL`.
fn campaign_matches_linux(trajectory: &str, duration: f64) {
    let dir = tempfile::tempdir().unwrap();
    for id in FMUS {
        std::fs::copy(built_fmu(id), dir.path().join(format!("{id}.fmu"))).unwrap();
    }
    let scenario = dir.path().join("scenario.toml");
    std::fs::write(
        &scenario,
        format!(
            r#"step_size = 0.001
stop_time = {duration:?}
trials = 3

[[fmu]]
name = "controller"
path = "HlcsController.fmu"
[fmu.parameters]
trajectory = "{trajectory}"
duration = {duration:?}
learning = true
psi = 7.5

[[fmu]]
name = "plant"
path = "CkcmPlant.fmu"

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

[record]
variables = ["controller.error", "controller.force", "controller.memory_next", "plant.length", "plant.pose"]

[metrics]
error = "controller.error"
pose = "plant.pose"
trajectory = {{ kind = "{trajectory}", duration = {duration:?}, home_height = 0.5 }}
"#
        ),
    )
    .unwrap();

    let linux = dir.path().join("linux");
    orchestrator()
        .arg("run")
        .arg(&scenario)
        .arg("--out")
        .arg(&linux)
        .assert()
        .success();
    let windows = dir.path().join("windows");
    let out = wine(&["run", &win_path(&scenario), "--out", &win_path(&windows)]);
    assert_success(&out, &format!("orchestrator.exe run ({trajectory})"));

    let mut files = vec![PathBuf::from("summary.csv"), PathBuf::from("memory.csv")];
    for k in 0..3 {
        files.push(Path::new("trials").join(format!("trial_{k:03}.csv")));
    }
    let mut worst = Differences::default();
    for f in &files {
        worst = worst.merge(assert_csv_close(&linux.join(f), &windows.join(f)));
    }
    // The file lists agree too (no extra or missing trial).
    let list = |d: &Path| {
        let mut names: Vec<_> = std::fs::read_dir(d.join("trials"))
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        names
    };
    assert_eq!(list(&linux), list(&windows));
    println!("{trajectory} campaign, Linux against Wine: {worst:?}");
}

#[test]
fn wine_line_campaign_matches_linux() {
    campaign_matches_linux("line", 15.0);
}

#[test]
fn wine_circle_campaign_matches_linux() {
    campaign_matches_linux("circle", 5.0);
}

/// `orchestrator.exe simulate` of each FMU alone (win64 DLL, resources at a `file:///C:/`
/// URI) against the Linux build.
#[test]
fn wine_simulate_each_fmu_matches_linux() {
    let dir = tempfile::tempdir().unwrap();
    let hold: Vec<String> = (1..=6).map(|i| format!("force[{i}]=28.5315")).collect();
    for (id, extra) in [("CkcmPlant", hold), ("HlcsController", Vec::new())] {
        let fmu = built_fmu(id);
        let linux = dir.path().join(format!("{id}-linux.csv"));
        let windows = dir.path().join(format!("{id}-windows.csv"));
        let mut args = vec!["simulate".to_owned(), "--stop-time".into(), "1.0".into()];
        for set in &extra {
            args.extend(["--set".to_owned(), set.clone()]);
        }
        orchestrator()
            .args(&args)
            .arg(&fmu)
            .arg("--output")
            .arg(&linux)
            .assert()
            .success();
        let mut wine_args: Vec<String> = args.clone();
        wine_args.extend([win_path(&fmu), "--output".into(), win_path(&windows)]);
        let refs: Vec<&str> = wine_args.iter().map(String::as_str).collect();
        let out = wine(&refs);
        assert_success(&out, &format!("orchestrator.exe simulate {id}"));
        let worst = assert_csv_close(&linux, &windows);
        println!("simulate {id}, Linux against Wine: {worst:?}");
    }
}

/// An FMU without `binaries/win64` fails on Windows with the folder looked in and the
/// platforms the archive has.
#[test]
fn wine_missing_win64_binary_names_the_platforms() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = dir.path().join("LinuxOnly.fmu");
    repackage(&built_fmu("CkcmPlant"), &fmu, |name, bytes| {
        (!name.starts_with("binaries/win64/")).then_some(bytes)
    });
    let out = wine(&["info", &win_path(&fmu)]);
    assert!(
        !out.status.success(),
        "info of a Linux-only FMU succeeded on Windows"
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains(
            "LinuxOnly.fmu: no binary for this platform (win64): expected \
             binaries/win64/CkcmPlant.dll inside the archive; the archive has binaries for linux64"
        ),
        "{stderr}"
    );
}
