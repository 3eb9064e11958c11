//! What makes a crate an FMU crate, read in one place: its `Cargo.toml` carries
//!
//! ```toml
//! [package.metadata.fmu]
//! model-description = "../modelDescription/CkcmPlant.xml"   # relative to the crate
//!
//! [lib]
//! crate-type = ["cdylib", "rlib"]
//! ```
//!
//! Its build script is then one line, [`generate`], which turns that XML into the Rust
//! tables the crate `include!`s; `cargo xtask fmu` packages every workspace member
//! [`workspace_fmus`] finds. Adding an FMU is therefore a new crate (XML, model, this
//! table, the one-line build script) plus its entry in the workspace `members`.
//!
//! The manifests are read with `toml` rather than through `cargo metadata`: a build script
//! must not run cargo (it would wait on the build's own lock), and one reader for both
//! sides keeps them from disagreeing. The workspace lists its members by path (no globs).
#![forbid(unsafe_code)]

use std::path::{Path, PathBuf};

use fmi2_md::ModelDescription;

#[cfg(feature = "package")]
pub mod linux64;
#[cfg(feature = "package")]
mod package;
#[cfg(feature = "package")]
pub use package::write_fmu;

/// The file `include!`d by an FMU crate: `concat!(env!("OUT_DIR"), "/model_description.rs")`.
pub const GENERATED_FILE: &str = "model_description.rs";

/// A problem with a manifest or a model description, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Manifest { path: PathBuf, message: String },
    /// The parser's error names the file and line itself.
    #[error("{0}")]
    ModelDescription(fmi2_md::MdError),
    #[error("{path} has problems:\n{}", problems.join("\n"))]
    Invalid {
        path: PathBuf,
        problems: Vec<String>,
    },
}

/// One FMU crate of the workspace.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FmuCrate {
    /// Cargo package name, e.g. `fmu-plant` (for `cargo build -p`).
    pub package: String,
    /// `[lib] name` (default: the package name with `-` as `_`): the shared library is
    /// `{DLL_PREFIX}{lib_name}{DLL_SUFFIX}` in the target directory.
    pub lib_name: String,
    /// The crate's directory.
    pub dir: PathBuf,
    /// Its model description, resolved against `dir`.
    pub model_description: PathBuf,
}

impl FmuCrate {
    /// Reads `dir/Cargo.toml`; `None` if it has no `[package.metadata.fmu]` table.
    pub fn read(dir: &Path) -> Result<Option<Self>, Error> {
        let path = dir.join("Cargo.toml");
        let manifest = read_toml(&path)?;
        let bad = |message: String| Error::Manifest {
            path: path.clone(),
            message,
        };
        let package = manifest
            .get("package")
            .and_then(toml::Value::as_table)
            .ok_or_else(|| bad("no [package] table".into()))?;
        let Some(fmu) = package
            .get("metadata")
            .and_then(|m| m.get("fmu"))
            .map(|f| {
                f.as_table()
                    .ok_or_else(|| bad("[package.metadata.fmu] is not a table".into()))
            })
            .transpose()?
        else {
            return Ok(None);
        };
        let name = package
            .get("name")
            .and_then(toml::Value::as_str)
            .ok_or_else(|| bad("package.name is missing".into()))?;
        let xml = fmu
            .get("model-description")
            .and_then(toml::Value::as_str)
            .ok_or_else(|| {
                bad("[package.metadata.fmu] needs model-description = \"<path of the XML>\"".into())
            })?;
        let lib = manifest.get("lib").and_then(toml::Value::as_table);
        let cdylib = lib
            .and_then(|l| l.get("crate-type"))
            .and_then(toml::Value::as_array)
            .is_some_and(|types| types.iter().any(|t| t.as_str() == Some("cdylib")));
        if !cdylib {
            return Err(bad(
                "an FMU crate needs [lib] crate-type = [\"cdylib\", ...]: the FMU's binary is its shared library"
                    .into(),
            ));
        }
        let lib_name = lib
            .and_then(|l| l.get("name"))
            .and_then(toml::Value::as_str)
            .map_or_else(|| name.replace('-', "_"), str::to_owned);
        Ok(Some(Self {
            package: name.to_owned(),
            lib_name,
            dir: dir.to_path_buf(),
            model_description: dir.join(xml),
        }))
    }

    /// Parses and validates the model description.
    pub fn load_model_description(&self) -> Result<ModelDescription, Error> {
        let path = &self.model_description;
        let md = ModelDescription::from_file(path).map_err(Error::ModelDescription)?;
        let mut problems: Vec<String> = md.validate().iter().map(ToString::to_string).collect();
        problems.extend(log_category_problem(&md));
        if !problems.is_empty() {
            return Err(Error::Invalid {
                path: path.clone(),
                problems,
            });
        }
        Ok(md)
    }
}

/// The export glue logs under the names of `fmi2_export::LOG_CATEGORIES`; a model
/// description must declare exactly those, in that order, or masters filter (and show)
/// messages under names the FMU never uses.
fn log_category_problem(md: &ModelDescription) -> Option<String> {
    let declared: Vec<&str> = md.log_categories.iter().map(|c| c.name.as_str()).collect();
    let glue: Vec<String> = fmi2_export::LOG_CATEGORIES
        .iter()
        .map(|c| c.to_string_lossy().into_owned())
        .collect();
    (declared != glue).then(|| {
        format!(
            "<LogCategories> declares {declared:?}; the export glue logs under {glue:?}, \
             which it must declare in this order"
        )
    })
}

/// Every FMU crate among the members of the workspace whose root is `root`, in the order
/// of `workspace.members`.
pub fn workspace_fmus(root: &Path) -> Result<Vec<FmuCrate>, Error> {
    let path = root.join("Cargo.toml");
    let manifest = read_toml(&path)?;
    let members = manifest
        .get("workspace")
        .and_then(|w| w.get("members"))
        .and_then(toml::Value::as_array)
        .ok_or_else(|| Error::Manifest {
            path: path.clone(),
            message: "no workspace.members list".into(),
        })?;
    let mut out = Vec::new();
    for member in members {
        let member = member.as_str().ok_or_else(|| Error::Manifest {
            path: path.clone(),
            message: format!("workspace member {member} is not a string"),
        })?;
        if member.contains(['*', '?', '[']) {
            return Err(Error::Manifest {
                path: path.clone(),
                message: format!(
                    "workspace member {member:?} is a glob; list members by path so the FMU \
                     crates can be found without cargo"
                ),
            });
        }
        if let Some(fmu) = FmuCrate::read(&root.join(member))? {
            out.push(fmu);
        }
    }
    Ok(out)
}

/// The body of an FMU crate's build script: reads the crate's `[package.metadata.fmu]`,
/// validates its model description and writes the generated tables (value references,
/// enumeration items, variable specs, start values) to `$OUT_DIR/`[`GENERATED_FILE`].
///
/// # Panics
/// On any problem, with the message naming the file: that is how a build script fails.
pub fn generate() {
    if let Err(e) = try_generate() {
        panic!("{e}");
    }
}

fn try_generate() -> Result<(), Error> {
    let dir = PathBuf::from(env("CARGO_MANIFEST_DIR"));
    let manifest = dir.join("Cargo.toml");
    println!("cargo::rerun-if-changed={}", manifest.display());
    let fmu = FmuCrate::read(&dir)?.ok_or_else(|| Error::Manifest {
        path: manifest,
        message: "fmu_build::generate needs a [package.metadata.fmu] table".into(),
    })?;
    println!(
        "cargo::rerun-if-changed={}",
        fmu.model_description.display()
    );
    let md = fmu.load_model_description()?;
    let out = PathBuf::from(env("OUT_DIR")).join(GENERATED_FILE);
    std::fs::write(&out, fmi2_md::codegen::codegen_rust(&md))
        .map_err(|source| Error::Io { path: out, source })
}

/// A variable cargo sets for every build script.
fn env(name: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| panic!("{name} is not set: run from a build script"))
}

fn read_toml(path: &Path) -> Result<toml::Table, Error> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    text.parse::<toml::Table>().map_err(|e| Error::Manifest {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}
