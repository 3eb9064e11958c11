//! `.fmu` archives: modelDescription.xml, binaries/linux64/<modelIdentifier>.so,
//! binaries/win64/<modelIdentifier>.dll (cross-built with mingw-w64),
//! documentation/index.html.

use std::fs;
use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::{FMUS, cargo, docs, run, target_dir, win64};

/// Builds both FMU crates in release mode, for Linux and for win64, and writes
/// `<target dir>/fmu/<id>.fmu`, from the libraries of the same target directory
/// (`$CARGO_TARGET_DIR` honoured).
pub fn build_fmus(root: &Path) -> Result<()> {
    win64::ensure_cross_toolchain()?;
    let target = target_dir(root);
    let mut cmd = Command::new(cargo());
    cmd.current_dir(root)
        .env("CARGO_TARGET_DIR", &target)
        .args(["build", "--release", "--quiet"]);
    for (package, _) in FMUS {
        cmd.args(["-p", package]);
    }
    run(&mut cmd)?;
    win64::cargo_build(root, &FMUS.map(|(package, _)| package))?;
    let out_dir = target.join("fmu");
    fs::create_dir_all(&out_dir).with_context(|| format!("cannot create {}", out_dir.display()))?;
    for (package, id) in FMUS {
        let lib = target
            .join("release")
            .join(format!("lib{}.so", package_lib_name(package)));
        let dll = win64::release_dir(&target).join(format!("{}.dll", package_lib_name(package)));
        let xml = root.join("modelDescription").join(format!("{id}.xml"));
        let fmu = out_dir.join(format!("{id}.fmu"));
        package_fmu(&xml, &lib, &dll, &fmu)?;
        println!("packaged {}", fmu.display());
    }
    Ok(())
}

/// The `[lib] name` of each FMU crate.
fn package_lib_name(package: &str) -> &'static str {
    match package {
        "fmu-plant" => "ckcm_plant",
        "fmu-controller" => "hlcs_controller",
        other => panic!("unknown FMU package {other}"),
    }
}

/// Writes one `.fmu` atomically (temporary file, then rename): `lib` is this platform's
/// binary, `win64_dll` goes to `binaries/win64/`.
pub fn package_fmu(xml: &Path, lib: &Path, win64_dll: &Path, fmu: &Path) -> Result<()> {
    let md_text =
        fs::read_to_string(xml).with_context(|| format!("cannot read {}", xml.display()))?;
    let md =
        fmi2::md::ModelDescription::parse(&md_text).with_context(|| xml.display().to_string())?;
    let problems = md.validate();
    if !problems.is_empty() {
        bail!("{} has problems: {problems:?}", xml.display());
    }
    // Written beside the target and renamed, so a failed build never leaves a torn .fmu.
    let tmp = fmu.with_extension("fmu.tmp");
    let docs = docs::index_html(&md);
    let dll =
        fs::read(win64_dll).with_context(|| format!("cannot read {}", win64_dll.display()))?;
    let dll_entry = format!(
        "binaries/win64/{}.dll",
        md.model_identifier().unwrap_or_default()
    );
    fmi2::import::write_fmu(
        &tmp,
        &md_text,
        Some(lib),
        &[
            (dll_entry.as_str(), dll.as_slice()),
            ("documentation/index.html", docs.as_bytes()),
        ],
    )
    .with_context(|| format!("cannot write {}", tmp.display()))?;
    fs::rename(&tmp, fmu).with_context(|| format!("cannot move {} into place", fmu.display()))?;
    Ok(())
}
