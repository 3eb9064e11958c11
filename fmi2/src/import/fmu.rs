//! Opening a .fmu: unzip, parse and validate the description, load the binary.

use std::ffi::{CStr, CString};
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::extract::ExtractionDir;
use super::functions::Functions;
use super::instance::Instance;
use super::{ImportError, PLATFORM, SHARED_LIBRARY_EXTENSION};
use crate::md::ModelDescription;
use crate::types::{FMI_VERSION, TYPES_PLATFORM};
use libloading::Library;

/// What every instance of an FMU shares. Field order is drop order: the function
/// pointers go first, then the library is unloaded, then the unpacked files removed.
#[derive(Debug)]
pub(crate) struct Loaded {
    pub(crate) functions: Functions,
    _library: Library,
    pub(crate) dir: ExtractionDir,
}

/// An opened FMI 2.0 co-simulation FMU: unpacked, validated and loaded.
///
/// Instances keep the library loaded, so they may outlive the `Fmu` they came from.
#[derive(Debug)]
pub struct Fmu {
    path: PathBuf,
    md: ModelDescription,
    loaded: Arc<Loaded>,
}

impl Fmu {
    /// Opens `path`: unzips it into a temporary directory `fmi2-import-<pid>-*` (removed
    /// when the last of the `Fmu` and its instances is dropped; see
    /// [`remove_extraction_dirs`](super::remove_extraction_dirs) for signals), parses and validates modelDescription.xml,
    /// requires `<CoSimulation>`, loads `binaries/<platform>/<modelIdentifier>.<ext>`
    /// and resolves all 34 FMI 2.0 co-simulation functions.
    pub fn open(path: impl AsRef<Path>) -> Result<Fmu, ImportError> {
        let path = path.as_ref().to_path_buf();
        let file = File::open(&path).map_err(|source| match source.kind() {
            std::io::ErrorKind::NotFound => ImportError::NotFound { path: path.clone() },
            _ => ImportError::Io {
                path: path.clone(),
                source,
            },
        })?;
        let mut archive = zip::ZipArchive::new(file).map_err(|e| ImportError::NotZip {
            path: path.clone(),
            detail: e.to_string(),
        })?;
        if archive.index_for_name("modelDescription.xml").is_none() {
            return Err(ImportError::NoModelDescription { path });
        }
        let dir = ExtractionDir::new().map_err(|source| ImportError::Io {
            path: std::env::temp_dir(),
            source,
        })?;
        // `extract` refuses entries that would escape the directory (zip-slip).
        archive
            .extract(dir.path())
            .map_err(|e| ImportError::Unpack {
                path: path.clone(),
                detail: e.to_string(),
            })?;

        let md_path = dir.path().join("modelDescription.xml");
        let md = ModelDescription::from_file(&md_path).map_err(|source| {
            ImportError::ModelDescription {
                path: path.clone(),
                source: source.in_file(Path::new("modelDescription.xml")),
            }
        })?;
        let problems = md.validate();
        if !problems.is_empty() {
            return Err(ImportError::InvalidModelDescription { path, problems });
        }
        let identifier = md
            .model_identifier()
            .ok_or_else(|| ImportError::ModelDescription {
                path: path.clone(),
                source: crate::md::MdError {
                    file: Some("modelDescription.xml".into()),
                    line: None,
                    kind: Box::new(crate::md::MdErrorKind::NoCoSimulation),
                },
            })?
            .to_owned();
        let relative = format!("binaries/{PLATFORM}/{identifier}.{SHARED_LIBRARY_EXTENSION}");
        let binary = dir.path().join(&relative);
        if !binary.is_file() {
            return Err(ImportError::MissingBinary {
                path,
                expected: relative,
            });
        }
        let resources = dir.path().join("resources");
        std::fs::create_dir_all(&resources).map_err(|source| ImportError::Io {
            path: resources,
            source,
        })?;

        // SAFETY: loading runs the library's initialisers. An FMU binary is code the user
        // chose to run; that trust is the premise of every FMI master.
        let library = unsafe { Library::new(&binary) }.map_err(|source| ImportError::Load {
            path: binary.clone(),
            source,
        })?;
        // SAFETY: the binary declares itself an FMI 2.0 FMU, whose exported functions have
        // the standard's signatures, which is how `Functions` types them.
        let functions = unsafe { Functions::load(&library) }.map_err(|(symbol, source)| {
            ImportError::MissingSymbol {
                path: binary.clone(),
                symbol,
                source,
            }
        })?;
        check_string(
            &binary,
            "fmi2GetVersion",
            functions.fmi2GetVersion,
            FMI_VERSION,
        )?;
        check_string(
            &binary,
            "fmi2GetTypesPlatform",
            functions.fmi2GetTypesPlatform,
            TYPES_PLATFORM,
        )?;

        Ok(Fmu {
            path,
            md,
            loaded: Arc::new(Loaded {
                functions,
                _library: library,
                dir,
            }),
        })
    }

    /// The parsed (and valid) model description.
    pub fn model_description(&self) -> &ModelDescription {
        &self.md
    }

    /// The .fmu file this was opened from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The directory the archive was unpacked into (removed on drop).
    pub fn unpacked_dir(&self) -> &Path {
        self.loaded.dir.path()
    }

    /// `fmuResourceLocation` for fmi2Instantiate: the `file://` URI of the unpacked
    /// `resources/` directory, percent-encoded, with a trailing slash.
    pub fn resource_uri(&self) -> String {
        file_uri(&self.loaded.dir.path().join("resources"))
    }

    /// Creates a co-simulation instance (fmi2Instantiate with this description's GUID,
    /// `visible = false`). A NULL result becomes an error carrying what the FMU logged.
    pub fn instantiate(
        &self,
        instance_name: &str,
        logging_on: bool,
    ) -> Result<Instance, ImportError> {
        let invalid = |message: String| ImportError::InvalidArgument {
            function: "fmi2Instantiate",
            instance: instance_name.to_owned(),
            message,
        };
        let name = CString::new(instance_name)
            .map_err(|_| invalid("instance name contains a NUL byte".into()))?;
        let guid = CString::new(self.md.guid.as_str())
            .map_err(|_| invalid("GUID contains a NUL byte".into()))?;
        let resources = CString::new(self.resource_uri())
            .map_err(|_| invalid("resource URI contains a NUL byte".into()))?;
        Instance::instantiate(
            Arc::clone(&self.loaded),
            name,
            &guid,
            &resources,
            logging_on,
        )
    }
}

/// Fails unless the binary's version string function returns `expected`.
fn check_string(
    binary: &Path,
    function: &'static str,
    f: unsafe extern "C" fn() -> *const std::ffi::c_char,
    expected: &'static CStr,
) -> Result<(), ImportError> {
    // SAFETY: a no-argument FMI function returning a static string (or NULL, handled).
    let ptr = unsafe { f() };
    let found = if ptr.is_null() {
        "NULL".to_owned()
    } else {
        // SAFETY: non-null; the standard makes it a NUL-terminated static string.
        unsafe { CStr::from_ptr(ptr) }
            .to_string_lossy()
            .into_owned()
    };
    let expected_str = expected.to_str().unwrap_or_default();
    if found == expected_str {
        Ok(())
    } else {
        Err(ImportError::Version {
            path: binary.to_path_buf(),
            function,
            found,
            expected: expected_str,
        })
    }
}

/// `file:///abs/path/` with every byte outside RFC 3986's unreserved set (and `/`)
/// percent-encoded. Hand-written: the workspace has no URL crate, and this is the
/// whole of what fmuResourceLocation needs.
pub fn file_uri(dir: &Path) -> String {
    let absolute = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
    #[cfg(unix)]
    let bytes = std::os::unix::ffi::OsStrExt::as_bytes(absolute.as_os_str()).to_vec();
    // Windows: `C:\x` becomes `/C:/x`, so the URI reads `file:///C:/x`.
    #[cfg(not(unix))]
    let bytes = format!("/{}", absolute.to_string_lossy().replace('\\', "/")).into_bytes();
    let mut uri = String::from("file://");
    for b in bytes {
        if b.is_ascii_alphanumeric() || matches!(b, b'-' | b'.' | b'_' | b'~' | b'/') {
            uri.push(char::from(b));
        } else {
            uri.push_str(&format!("%{b:02X}"));
        }
    }
    if !uri.ends_with('/') {
        uri.push('/');
    }
    uri
}

#[cfg(test)]
mod tests {
    use super::file_uri;
    use std::path::Path;

    #[test]
    fn file_uri_percent_encodes() {
        assert_eq!(
            file_uri(Path::new("/tmp/a b/résumé")),
            "file:///tmp/a%20b/r%C3%A9sum%C3%A9/"
        );
        assert_eq!(
            file_uri(Path::new("/tmp/x/resources/")),
            "file:///tmp/x/resources/"
        );
        assert_eq!(file_uri(Path::new("/t/100%#?")), "file:///t/100%25%23%3F/");
    }
}
