//! `.fmu` archives: modelDescription.xml, binaries/linux64/<modelIdentifier>.so (linked
//! for glibc 2.17 with Zig), binaries/win64/<modelIdentifier>.dll (cross-built with
//! mingw-w64),
//! documentation/index.html.

use std::fs;
use std::path::Path;

use anyhow::{Context, Result, bail};

use crate::{docs, linux64, target_dir, win64};

/// Builds every FMU crate of the workspace (the members with a `[package.metadata.fmu]`
/// table, found by `fmu_build::workspace_fmus`) in release mode, for Linux and for win64,
/// and writes `<target dir>/fmu/<modelIdentifier>.fmu`, from the libraries of the same
/// target directory (`$CARGO_TARGET_DIR` honoured).
pub fn build_fmus(root: &Path) -> Result<()> {
    let fmus = fmu_build::workspace_fmus(root)?;
    if fmus.is_empty() {
        bail!(
            "no workspace member of {} has a [package.metadata.fmu] table",
            root.display()
        );
    }
    let packages: Vec<&str> = fmus.iter().map(|f| f.package.as_str()).collect();
    win64::ensure_cross_toolchain()?;
    let tools = linux64::ensure_tools(root)?;
    let target = target_dir(root);
    linux64::cargo_build(root, &tools, &packages)?;
    win64::cargo_build(root, &packages)?;
    let out_dir = target.join("fmu");
    fs::create_dir_all(&out_dir).with_context(|| format!("cannot create {}", out_dir.display()))?;
    for fmu in &fmus {
        let md = fmu.load_model_description()?;
        let id = md.model_identifier().with_context(|| {
            format!(
                "{} has no CoSimulation modelIdentifier",
                fmu.model_description.display()
            )
        })?;
        let lib = linux64::release_dir(root).join(format!("lib{}.so", fmu.lib_name));
        let dll = win64::release_dir(&target).join(win64::dll_file_name(&fmu.lib_name));
        let out = out_dir.join(format!("{id}.fmu"));
        package_fmu(&fmu.model_description, &lib, &dll, &out)?;
        println!("packaged {}", out.display());
    }
    Ok(())
}

/// Writes one `.fmu` atomically (temporary file, then rename): `lib` is this platform's
/// binary, `win64_dll` goes to `binaries/win64/`.
pub fn package_fmu(xml: &Path, lib: &Path, win64_dll: &Path, fmu: &Path) -> Result<()> {
    let md_text =
        fs::read_to_string(xml).with_context(|| format!("cannot read {}", xml.display()))?;
    let md =
        fmi2_md::ModelDescription::parse(&md_text).with_context(|| xml.display().to_string())?;
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
    fmu_build::write_fmu(
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
