//! The FMU crates are found from the manifests alone, and a malformed table is an error
//! naming the manifest.

use std::path::{Path, PathBuf};

use fmu_build::{Error, FmuCrate, workspace_fmus};

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn the_workspace_has_three_fmu_crates_with_their_libraries_and_models() {
    let fmus = workspace_fmus(&workspace_root()).unwrap();
    let found: Vec<(&str, &str)> = fmus
        .iter()
        .map(|f| (f.package.as_str(), f.lib_name.as_str()))
        .collect();
    assert_eq!(
        found,
        [
            ("fmu-plant", "ckcm_plant"),
            ("fmu-controller", "hlcs_controller"),
            ("foreign-fmu", "foreign_fmu"),
        ]
    );
    let ids: Vec<String> = fmus
        .iter()
        .map(|f| {
            let md = f.load_model_description().unwrap();
            md.model_identifier().unwrap().to_owned()
        })
        .collect();
    assert_eq!(ids, ["CkcmPlant", "HlcsController", "ForeignOscillator"]);
}

fn write(dir: &Path, file: &str, text: &str) {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join(file), text).unwrap();
}

#[test]
fn lib_name_defaults_to_the_package_name_and_other_crates_are_skipped() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    write(
        root,
        "Cargo.toml",
        "[workspace]\nmembers = [\"a-fmu\", \"plain\"]\n",
    );
    write(
        &root.join("a-fmu"),
        "Cargo.toml",
        "[package]\nname = \"a-fmu\"\n[package.metadata.fmu]\nmodel-description = \"md.xml\"\n\
         [lib]\ncrate-type = [\"cdylib\"]\n",
    );
    write(
        &root.join("plain"),
        "Cargo.toml",
        "[package]\nname = \"plain\"\n",
    );
    let fmus = workspace_fmus(root).unwrap();
    assert_eq!(
        fmus,
        [FmuCrate {
            package: "a-fmu".into(),
            lib_name: "a_fmu".into(),
            dir: root.join("a-fmu"),
            model_description: root.join("a-fmu").join("md.xml"),
        }]
    );
    // The XML does not exist: the error names it.
    let err = fmus[0].load_model_description().unwrap_err().to_string();
    assert!(err.contains("md.xml"), "{err}");
}

#[test]
fn malformed_tables_are_errors_naming_the_manifest() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    for (manifest, expected) in [
        (
            "[package]\nname = \"x\"\n[package.metadata.fmu]\nmodel-description = \"m.xml\"\n",
            "crate-type",
        ),
        (
            "[package]\nname = \"x\"\n[package.metadata.fmu]\n[lib]\ncrate-type = [\"cdylib\"]\n",
            "model-description",
        ),
        (
            "[package]\nname = \"x\"\n[package.metadata]\nfmu = 3\n",
            "not a table",
        ),
        ("[package\n", "Cargo.toml"),
    ] {
        write(dir, "Cargo.toml", manifest);
        let err = FmuCrate::read(dir).unwrap_err();
        assert!(matches!(err, Error::Manifest { .. }), "{err:?}");
        let text = err.to_string();
        assert!(text.contains(expected), "{manifest}: {text}");
        assert!(
            text.contains(&dir.join("Cargo.toml").display().to_string()),
            "{text}"
        );
    }
    write(dir, "Cargo.toml", "[workspace]\nmembers = [\"crates/*\"]\n");
    let err = workspace_fmus(dir).unwrap_err().to_string();
    assert!(err.contains("glob"), "{err}");
}

#[test]
fn log_categories_other_than_the_glue_logs_under_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let xml = std::fs::read_to_string(
        workspace_root().join("tests/fixtures/foreign-fmu/modelDescription.xml"),
    )
    .unwrap();
    let line =
        "<Category name=\"logStatusDiscard\" description=\"Calls that return fmi2Discard\"/>";
    assert!(xml.contains(line));
    write(dir, "md.xml", &xml.replace(line, ""));
    write(
        dir,
        "Cargo.toml",
        "[package]\nname = \"x\"\n[package.metadata.fmu]\nmodel-description = \"md.xml\"\n\
         [lib]\ncrate-type = [\"cdylib\"]\n",
    );
    let fmu = FmuCrate::read(dir).unwrap().unwrap();
    let err = fmu.load_model_description().unwrap_err().to_string();
    assert!(
        err.contains("md.xml")
            && err.contains("<LogCategories>")
            && err.contains("logStatusDiscard"),
        "{err}"
    );
}
