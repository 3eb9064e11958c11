//! The FMU binaries do not depend on where the checkout lies: a campaign's fingerprint holds
//! its FMU files' bytes, so two clones of one commit must build the same FMUs for
//! `run --resume` and `sweep merge` to accept each other's results. Debug info once made
//! them differ (the checkout's paths fed LLVM's names for promoted symbols).

mod common;

use std::path::Path;
use std::process::Command;

use common::{archive_entry, built_fmu, workspace_root};
use fmu_build::linux64::{Tools, release_dir};

/// Copies the tracked files of the checkout, as they are now, below `to`.
fn copy_checkout(to: &Path) {
    let root = workspace_root();
    let listed = Command::new("git")
        .args(["ls-files", "-z"])
        .current_dir(&root)
        .output()
        .expect("git runs");
    assert!(listed.status.success(), "git ls-files failed");
    for name in listed.stdout.split(|&b| b == 0).filter(|n| !n.is_empty()) {
        let name = std::str::from_utf8(name).expect("tracked paths are UTF-8");
        let (from, dest) = (root.join(name), to.join(name));
        // A tracked file deleted in the working tree is not part of the build.
        if !from.exists() {
            continue;
        }
        std::fs::create_dir_all(dest.parent().unwrap()).unwrap();
        std::fs::copy(&from, &dest).unwrap_or_else(|e| panic!("{}: {e}", from.display()));
    }
}

/// The build tools `cargo xtask fmu` installed, where it installs them (`$CKCM_TOOLS_DIR`,
/// set by `cargo xtask test`, else `<workspace>/target/tools`).
fn installed_tools() -> Tools {
    let tools = Tools::from_env(&workspace_root().join("target"));
    assert!(
        tools.cargo_zigbuild().is_file() && tools.python().is_file(),
        "cargo-zigbuild or Zig is missing from {}: run `cargo xtask fmu` (or point \
         CKCM_TOOLS_DIR at its tools)",
        tools.dir().display()
    );
    tools
}

/// Builds the plant in another folder, with a target directory of its own and the same
/// command as `cargo xtask fmu`, and compares its library with the one packaged in
/// `CkcmPlant.fmu` (several minutes: every dependency is compiled again).
#[test]
fn the_plant_builds_the_same_library_in_another_folder() {
    let packaged = archive_entry(&built_fmu("CkcmPlant"), "binaries/linux64/CkcmPlant.so");
    let tools = installed_tools();
    let dir = tempfile::tempdir().unwrap();
    let checkout = dir.path().join("elsewhere");
    copy_checkout(&checkout);
    let target = dir.path().join("target");
    let status = tools
        .build_command(&target)
        .args(["--offline", "-p", "fmu-plant"])
        .current_dir(&checkout)
        .status()
        .expect("cargo zigbuild runs");
    assert!(
        status.success(),
        "the build in {} failed",
        checkout.display()
    );
    let built = std::fs::read(release_dir(&target).join("libckcm_plant.so")).unwrap();
    assert!(
        built == packaged,
        "the plant built in {} differs from the packaged one ({} and {} bytes)",
        checkout.display(),
        built.len(),
        packaged.len()
    );
}
