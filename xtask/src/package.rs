//! `.fmu` archives: modelDescription.xml, binaries/linux64/<modelIdentifier>.so,
//! documentation/index.html.

use std::fs;
use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::{FMUS, cargo, docs, run, target_dir};

/// Builds both FMU crates in release mode and writes `<target dir>/fmu/<id>.fmu`, from the
/// libraries of the same target directory (`$CARGO_TARGET_DIR` honoured).
pub fn build_fmus(root: &Path) -> Result<()> {
    let target = target_dir(root);
    let mut cmd = Command::new(cargo());
    cmd.current_dir(root)
        .env("CARGO_TARGET_DIR", &target)
        .args(["build", "--release", "--quiet"]);
    for (package, _) in FMUS {
        cmd.args(["-p", package]);
    }
    run(&mut cmd)?;
    let out_dir = target.join("fmu");
    fs::create_dir_all(&out_dir).with_context(|| format!("cannot create {}", out_dir.display()))?;
    for (package, id) in FMUS {
        let lib = target
            .join("release")
            .join(format!("lib{}.so", package_lib_name(package)));
        let xml = root.join("modelDescription").join(format!("{id}.xml"));
        let fmu = out_dir.join(format!("{id}.fmu"));
        package_fmu(&xml, &lib, &fmu)?;
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

/// Writes one `.fmu` atomically (temporary file, then rename).
pub fn package_fmu(xml: &Path, lib: &Path, fmu: &Path) -> Result<()> {
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
    fmi2::import::write_fmu(
        &tmp,
        &md_text,
        Some(lib),
        &[("documentation/index.html", docs.as_bytes())],
    )
    .with_context(|| format!("cannot write {}", tmp.display()))?;
    fs::rename(&tmp, fmu).with_context(|| format!("cannot move {} into place", fmu.display()))?;
    Ok(())
}
