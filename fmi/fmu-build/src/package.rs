//! Writing a .fmu archive: for the packaging task and for tests that have a built cdylib.

use std::fs::File;
use std::io::Write;
use std::path::Path;

use zip::write::SimpleFileOptions;

use fmi2_md::ModelDescription;
use fmi2_sys::{PLATFORM, SHARED_LIBRARY_EXTENSION};

use crate::Error;

/// Writes an FMU archive to `out`: `modelDescription.xml` from `model_description`,
/// the `cdylib` (if given) as `binaries/<platform>/<modelIdentifier>.<ext>` with the
/// identifier taken from the description, and each `(path, bytes)` of `files` at that path
/// inside the archive (e.g. `resources/table.csv`, `documentation/index.html`).
///
/// Passing `None` for the binary (or any XML text) lets tests build broken archives.
pub fn write_fmu(
    out: &Path,
    model_description: &str,
    cdylib: Option<&Path>,
    files: &[(&str, &[u8])],
) -> Result<(), Error> {
    let io = |source| Error::Io {
        path: out.to_path_buf(),
        source,
    };
    let zip_err = |e: zip::result::ZipError| io(std::io::Error::other(e));
    let options = SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);

    let binary = match cdylib {
        Some(lib) => {
            let md = ModelDescription::parse(model_description)
                .map_err(|e| Error::ModelDescription(e.in_file(out)))?;
            let identifier = md.model_identifier().unwrap_or_default().to_owned();
            let bytes = std::fs::read(lib).map_err(|source| Error::Io {
                path: lib.to_path_buf(),
                source,
            })?;
            Some((
                format!("binaries/{PLATFORM}/{identifier}.{SHARED_LIBRARY_EXTENSION}"),
                bytes,
            ))
        }
        None => None,
    };

    let mut zip = zip::ZipWriter::new(File::create(out).map_err(io)?);
    zip.start_file("modelDescription.xml", options)
        .map_err(zip_err)?;
    zip.write_all(model_description.as_bytes()).map_err(io)?;
    if let Some((name, bytes)) = binary {
        zip.start_file(name, options.unix_permissions(0o755))
            .map_err(zip_err)?;
        zip.write_all(&bytes).map_err(io)?;
    }
    for (name, bytes) in files {
        zip.start_file(*name, options).map_err(zip_err)?;
        zip.write_all(bytes).map_err(io)?;
    }
    zip.finish().map_err(zip_err)?;
    Ok(())
}
