//! Opening a .fmu: unzip, parse and validate the description, load the binary.

use std::ffi::{CStr, CString};
use std::fs::File;
use std::io::{Cursor, Read, Seek};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::ImportError;
use crate::extract::ExtractionDir;
use crate::functions::Functions;
use crate::instance::Instance;
use fmi2_md::ModelDescription;
use fmi2_sys::{FMI_VERSION, TYPES_PLATFORM};
use fmi2_sys::{PLATFORM, SHARED_LIBRARY_EXTENSION};
use libloading::Library;

/// What `path` is when it exists but is no regular file, folder or link to one.
fn special_file_kind(path: &Path) -> Option<&'static str> {
    let file_type = std::fs::metadata(path).ok()?.file_type();
    if file_type.is_file() || file_type.is_dir() {
        return None;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return Some("a named pipe (FIFO)");
        }
        if file_type.is_socket() {
            return Some("a socket");
        }
        if file_type.is_char_device() || file_type.is_block_device() {
            return Some("a device");
        }
    }
    Some("no regular file")
}

/// Why the file at `path` is no zip archive, from its first bytes where they tell what it is
/// (a user who gives the model's library, its modelDescription.xml or a scenario file learns
/// so), else the zip reader's own reason.
fn not_zip_detail(path: &Path, zip_detail: String) -> String {
    const FMU: &str = "an FMU is a zip archive with modelDescription.xml at its root and the \
                       model's libraries under binaries/<platform>/";
    let mut head = Vec::new();
    if File::open(path)
        .and_then(|f| f.take(1024).read_to_end(&mut head))
        .is_err()
    {
        return format!("the zip reader says: {zip_detail}");
    }
    let text = match std::str::from_utf8(&head) {
        Ok(text) => Some(text),
        // The first 1024 bytes may end inside a character.
        Err(e) if e.error_len().is_none() => std::str::from_utf8(&head[..e.valid_up_to()]).ok(),
        Err(_) => None,
    }
    .filter(|t| !t.contains('\0'))
    .map(|t| t.trim_start_matches('\u{feff}').trim_start());
    let kind = match head.as_slice() {
        [] => return "the file is empty".to_owned(),
        [b'P', b'K', ..] => {
            return format!("it begins like one but is damaged or cut short: {zip_detail}");
        }
        [0x7f, b'E', b'L', b'F', ..] => "an ELF shared library or program",
        [b'M', b'Z', ..] => "a Windows DLL or program",
        [0xcf, 0xfa, 0xed, 0xfe, ..]
        | [0xfe, 0xed, 0xfa, 0xcf, ..]
        | [0xca, 0xfe, 0xba, 0xbe, ..] => "a macOS library or program",
        [0x1f, 0x8b, ..] => "gzip-compressed (a .tar.gz?)",
        _ => match text {
            Some(t) if t.starts_with('<') => "XML text (a modelDescription.xml alone?)",
            Some(_) => "a text file",
            None => return format!("the zip reader says: {zip_detail}"),
        },
    };
    format!("it is {kind}; {FMU}")
}

/// An FMU unpacked with its description parsed and validated, its binary not yet loaded.
struct Unpacked {
    path: PathBuf,
    md: ModelDescription,
    /// The platform folders under `binaries/` in the archive, sorted.
    platforms: Vec<String>,
    dir: ExtractionDir,
    identifier: String,
}

impl Unpacked {
    /// [`Fmu::open`] up to loading the binary.
    fn open(path: &Path) -> Result<Unpacked, ImportError> {
        let path = path.to_path_buf();
        if path.is_dir() {
            let unpacked = path.join("modelDescription.xml").is_file();
            return Err(ImportError::Folder { path, unpacked });
        }
        // Opening a named pipe waits for a writer, possibly forever; a zip reader needs to
        // seek, which no pipe, socket or device offers.
        if let Some(kind) = special_file_kind(&path) {
            return Err(ImportError::NotZip {
                detail: format!("it is {kind}; an FMU is a regular file the reader can seek in"),
                path,
            });
        }
        let file = File::open(&path).map_err(|source| match source.kind() {
            std::io::ErrorKind::NotFound => ImportError::NotFound { path: path.clone() },
            _ => ImportError::Io {
                path: path.clone(),
                source,
            },
        })?;
        let mut archive = zip::ZipArchive::new(file).map_err(|e| ImportError::NotZip {
            detail: not_zip_detail(&path, e.to_string()),
            path: path.clone(),
        })?;
        if archive.index_for_name("modelDescription.xml").is_none() {
            return Err(ImportError::NoModelDescription { path });
        }
        let dir = ExtractionDir::new().map_err(|source| ImportError::Io {
            path: std::env::temp_dir(),
            source,
        })?;
        let platforms = platforms_in(&archive);
        max_unpacked_bytes()
            .and_then(|limit| unpack(&mut archive, dir.path(), limit))
            .map_err(|detail| ImportError::Unpack {
                path: path.clone(),
                detail,
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
                source: fmi2_md::MdError {
                    file: Some("modelDescription.xml".into()),
                    line: None,
                    kind: Box::new(fmi2_md::MdErrorKind::NoCoSimulation),
                },
            })?
            .to_owned();
        Ok(Unpacked {
            path,
            md,
            platforms,
            dir,
            identifier,
        })
    }
}

/// The model description and the platform folders of the FMU at `path`, read and checked
/// as [`Fmu::open`] reads them, without loading its binary: for a tool that shows an FMU
/// that cannot run here (no binary for this platform, or one that does not load).
pub fn read_description(
    path: impl AsRef<Path>,
) -> Result<(ModelDescription, Vec<String>), ImportError> {
    let unpacked = Unpacked::open(path.as_ref())?;
    Ok((unpacked.md, unpacked.platforms))
}

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
/// Instances keep the library loaded, so they may outlive the `Fmu` they came from. A clone
/// is another handle to the same loaded library (as with `Arc`), whose instances share its
/// process-wide state; opening the file again gives a separate copy.
#[derive(Debug, Clone)]
pub struct Fmu {
    path: PathBuf,
    md: ModelDescription,
    /// The platform folders under `binaries/` in the archive, sorted.
    platforms: Vec<String>,
    loaded: Arc<Loaded>,
}

impl Fmu {
    /// Opens `path`: unzips it, except other platforms' binaries, into a temporary
    /// directory `fmi2-import-<pid>-*` (removed when the last of the `Fmu` and its
    /// instances is dropped; see
    /// [`remove_extraction_dirs`](super::remove_extraction_dirs) for signals), parses and validates modelDescription.xml,
    /// requires `<CoSimulation>`, loads `binaries/<platform>/<modelIdentifier>.<ext>`
    /// and resolves all 34 FMI 2.0 co-simulation functions.
    pub fn open(path: impl AsRef<Path>) -> Result<Fmu, ImportError> {
        let Unpacked {
            path,
            md,
            platforms,
            dir,
            identifier,
        } = Unpacked::open(path.as_ref())?;
        let relative = format!("binaries/{PLATFORM}/{identifier}.{SHARED_LIBRARY_EXTENSION}");
        let binary = dir.path().join(&relative);
        if !binary.is_file() {
            return Err(ImportError::MissingBinary {
                path,
                platform: PLATFORM,
                expected: relative,
                available: platforms,
            });
        }
        let resources = dir.path().join("resources");
        std::fs::create_dir_all(&resources).map_err(|source| ImportError::Io {
            path: resources,
            source,
        })?;

        let load_error = |reason: String| ImportError::Load {
            path: path.clone(),
            binary: relative.as_str().into(),
            reason: reason.into(),
        };
        let data = std::fs::read(&binary).map_err(|e| load_error(e.to_string()))?;
        crate::binary::check_complete(&data).map_err(load_error)?;
        drop(data);
        // SAFETY: loading runs the library's initialisers. An FMU binary is code the user
        // chose to run; that trust is the premise of every FMI master.
        let library = unsafe { Library::new(&binary) }
            .map_err(|e| load_error(loader_reason(&e, &binary, &relative)))?;
        // SAFETY: the binary declares itself an FMI 2.0 FMU, whose exported functions have
        // the standard's signatures, which is how `Functions` types them.
        let functions = unsafe { Functions::load(&library) }.map_err(|(symbol, source)| {
            ImportError::MissingSymbol {
                path: path.clone(),
                binary: relative.as_str().into(),
                symbol,
                reason: loader_reason(&source, &binary, &relative).into(),
            }
        })?;
        let version_error = |function, found, expected| ImportError::Version {
            path: path.clone(),
            binary: relative.as_str().into(),
            function,
            found,
            expected,
        };
        check_string(
            "fmi2GetVersion",
            functions.fmi2GetVersion,
            FMI_VERSION,
            version_error,
        )?;
        check_string(
            "fmi2GetTypesPlatform",
            functions.fmi2GetTypesPlatform,
            TYPES_PLATFORM,
            version_error,
        )?;

        Ok(Fmu {
            path,
            md,
            platforms,
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

    /// The platform folders under `binaries/` in the archive (e.g. `linux64`, `win64`),
    /// sorted.
    pub fn platforms(&self) -> Vec<String> {
        self.platforms.clone()
    }

    /// The directory the archive was unpacked into (removed on drop): everything but the
    /// binaries of other platforms.
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

/// The folder of `binaries/<folder>/...`, if `name` is an entry inside one.
fn platform_of(name: &str) -> Option<&str> {
    let rest = name.strip_prefix("binaries/")?;
    let (folder, _) = rest.split_once('/')?;
    (!folder.is_empty()).then_some(folder)
}

/// The platform folders under `binaries/` in the archive, sorted; none if it has none.
fn platforms_in<R: Read + Seek>(archive: &zip::ZipArchive<R>) -> Vec<String> {
    let mut names: Vec<String> = archive
        .file_names()
        .filter_map(|n| n.ok())
        .filter_map(|n| platform_of(&n).map(str::to_owned))
        .collect();
    names.sort();
    names.dedup();
    names
}

/// Unzips `archive` into `dir`, leaving out the binaries of other platforms: a master needs
/// only its own, and they can be most of an FMU (the shipped FMUs' win64 DLLs are 70 % of
/// what a Linux master would otherwise inflate and write on every open).
///
/// The wanted entries are first copied, still compressed, into an archive in memory, which
/// the `zip` crate then extracts: its `extract` keeps entries from escaping `dir` (zip-slip)
/// and resolves symbolic links safely, and it has no per-entry filter of its own. When the
/// wanted entries are too big to copy in memory (over [`COPY_LIMIT`] compressed), or should
/// the copy fail, everything is extracted as before.
///
/// The entries' declared sizes must add up to no more than `limit` bytes (the reader stops
/// an entry that inflates past its declared size), so a zip bomb is refused before anything
/// is written instead of filling the disk.
fn unpack<R: Read + Seek>(
    archive: &mut zip::ZipArchive<R>,
    dir: &Path,
    limit: u64,
) -> Result<(), String> {
    // Only a plain relative name may be left out: any other stays for `extract` to judge,
    // so `binaries/win64/../../x` is refused as before instead of silently skipped.
    let plain = |name: &str| {
        !name.starts_with('/')
            && !name.contains(['\\', ':', '\0'])
            && name.split('/').all(|c| c != ".." && c != ".")
    };
    let foreign = |name: &str| plain(name) && platform_of(name).is_some_and(|p| p != PLATFORM);
    // An entry whose name cannot be read stays: extracting it reports the problem.
    let wanted: Vec<usize> = (0..archive.len())
        .filter(|&i| !matches!(archive.name_for_index(i), Some(Ok(n)) if foreign(&n)))
        .collect();
    let mut total = 0u64;
    for &i in &wanted {
        let size = archive.by_index_raw(i).map_err(|e| e.to_string())?.size();
        total = total.saturating_add(size);
    }
    if total > limit {
        return Err(format!(
            "its files unpack to {:.1} MiB, more than the limit of {} MiB (set \
             {MAX_UNPACKED_VAR} to a number of MiB to allow more)",
            total as f64 / f64::from(1 << 20),
            limit >> 20
        ));
    }
    let result = if wanted.len() == archive.len() {
        archive.extract(dir)
    } else {
        match copy_entries(archive, &wanted) {
            Ok(mut own) => own.extract(dir),
            Err(_) => archive.extract(dir),
        }
    };
    result.map_err(|e| e.to_string())
}

/// Environment variable raising (or lowering) [`DEFAULT_MAX_UNPACKED_MIB`].
pub const MAX_UNPACKED_VAR: &str = "FMI2_IMPORT_MAX_UNPACKED_MIB";

/// Most MiB an FMU may unpack to unless [`MAX_UNPACKED_VAR`] says otherwise: far above
/// real FMUs (the shipped ones unpack to about 10 MiB), far below a full disk.
pub const DEFAULT_MAX_UNPACKED_MIB: u64 = 2048;

/// The unpacking limit in bytes.
fn max_unpacked_bytes() -> Result<u64, String> {
    let mib = match std::env::var(MAX_UNPACKED_VAR) {
        Err(_) => DEFAULT_MAX_UNPACKED_MIB,
        Ok(v) => v
            .trim()
            .parse::<u64>()
            .map_err(|_| format!("{MAX_UNPACKED_VAR} = {v:?} is not a whole number of MiB"))?,
    };
    Ok(mib.saturating_mul(1 << 20))
}

/// The most compressed bytes [`unpack`] copies into memory to leave other platforms'
/// binaries out; an FMU with bigger resources is extracted whole instead.
const COPY_LIMIT: u64 = 64 << 20;

/// The entries `wanted` of `archive`, copied without recompressing into an archive in memory;
/// an error once they pass [`COPY_LIMIT`].
fn copy_entries<R: Read + Seek>(
    archive: &mut zip::ZipArchive<R>,
    wanted: &[usize],
) -> zip::result::ZipResult<zip::ZipArchive<Cursor<Vec<u8>>>> {
    let mut out = zip::ZipWriter::new(Cursor::new(Vec::new()));
    let mut size = 0u64;
    for &i in wanted {
        let entry = archive.by_index_raw(i)?;
        size = size.saturating_add(entry.compressed_size());
        if size > COPY_LIMIT {
            return Err(zip::result::ZipError::UnsupportedArchive(
                "entries too big to copy in memory",
            ));
        }
        out.raw_copy_file(entry)?;
    }
    out.finish_into_readable()
}

/// Fails unless the binary's version string function returns `expected`.
fn check_string(
    function: &'static str,
    f: unsafe extern "C" fn() -> *const std::ffi::c_char,
    expected: &'static CStr,
    error: impl Fn(&'static str, String, &'static str) -> ImportError,
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
        Err(error(function, found, expected_str))
    }
}

/// The loader's error with its cause: libloading keeps dlerror()'s text ("file too short",
/// "undefined symbol: ...") in the source, not in its own message. The unpacked binary's
/// temporary path in that text becomes its path inside the archive.
fn loader_reason(e: &libloading::Error, unpacked: &Path, relative: &str) -> String {
    let text = match std::error::Error::source(e) {
        Some(cause) => format!("{e}: {cause}"),
        None => e.to_string(),
    };
    text.replace(&*unpacked.to_string_lossy(), relative)
}

/// `file:///abs/path/` with every byte outside RFC 3986's unreserved set (and `/`)
/// percent-encoded; on Windows `file:///C:/abs/path/`. Hand-written: the workspace has no
/// URL crate, and this is the whole of what fmuResourceLocation needs.
pub fn file_uri(dir: &Path) -> String {
    let absolute = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
    #[cfg(unix)]
    let uri = unix_file_uri(std::os::unix::ffi::OsStrExt::as_bytes(absolute.as_os_str()));
    #[cfg(not(unix))]
    let uri = windows_file_uri(&absolute.to_string_lossy());
    uri
}

/// The URI of an absolute Unix path (its bytes).
#[cfg_attr(not(unix), allow(dead_code))]
fn unix_file_uri(path: &[u8]) -> String {
    let mut uri = String::from("file://");
    percent_encode_into(&mut uri, path);
    finish_dir_uri(uri)
}

/// The URI of an absolute Windows path: `C:\x` becomes `file:///C:/x` (the form Windows
/// FMI tools expect, RFC 8089 with the drive colon kept), a UNC path `\\server\share\x`
/// becomes `file://server/share/x`. The verbatim prefixes `\\?\` and `\\?\UNC\` (from
/// `std::fs::canonicalize`) are dropped.
#[cfg_attr(unix, allow(dead_code))]
fn windows_file_uri(path: &str) -> String {
    let path = path.replace('\\', "/");
    let path = if let Some(unc) = path.strip_prefix("//?/UNC/") {
        format!("//{unc}")
    } else if let Some(local) = path.strip_prefix("//?/") {
        local.to_owned()
    } else {
        path
    };
    let mut uri = String::from("file://");
    let bytes = path.as_bytes();
    if let Some(unc) = path.strip_prefix("//") {
        // The server name is the URI's authority.
        percent_encode_into(&mut uri, unc.as_bytes());
    } else if bytes.len() >= 2 && bytes[0].is_ascii_alphabetic() && bytes[1] == b':' {
        uri.push('/');
        uri.push(char::from(bytes[0]));
        uri.push(':');
        percent_encode_into(&mut uri, &bytes[2..]);
    } else {
        percent_encode_into(&mut uri, bytes);
    }
    finish_dir_uri(uri)
}

/// Appends `bytes`, keeping RFC 3986's unreserved characters and `/`, encoding the rest.
fn percent_encode_into(uri: &mut String, bytes: &[u8]) {
    for &b in bytes {
        if b.is_ascii_alphanumeric() || matches!(b, b'-' | b'.' | b'_' | b'~' | b'/') {
            uri.push(char::from(b));
        } else {
            uri.push_str(&format!("%{b:02X}"));
        }
    }
}

/// A directory URI ends with a slash.
fn finish_dir_uri(mut uri: String) -> String {
    if !uri.ends_with('/') {
        uri.push('/');
    }
    uri
}

#[cfg(test)]
mod tests {
    use super::{file_uri, unpack, windows_file_uri};
    use std::io::{Cursor, Write};
    use std::path::Path;

    /// An archive of a small file and 2 MiB of zeros (which deflate to about 2 KiB).
    fn zeros_archive() -> zip::ZipArchive<Cursor<Vec<u8>>> {
        let mut w = zip::ZipWriter::new(Cursor::new(Vec::new()));
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        w.start_file("modelDescription.xml", opts).unwrap();
        w.write_all(b"<x/>").unwrap();
        w.start_file("resources/zeros.bin", opts).unwrap();
        w.write_all(&vec![0u8; 2 << 20]).unwrap();
        w.finish_into_readable().unwrap()
    }

    #[test]
    fn an_archive_beyond_the_unpacking_limit_is_refused_before_writing() {
        let dir = tempfile::tempdir().unwrap();
        let err = unpack(&mut zeros_archive(), dir.path(), 1 << 20).unwrap_err();
        assert_eq!(
            err,
            "its files unpack to 2.0 MiB, more than the limit of 1 MiB (set \
             FMI2_IMPORT_MAX_UNPACKED_MIB to a number of MiB to allow more)"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        unpack(&mut zeros_archive(), dir.path(), 3 << 20).unwrap();
        let unpacked = std::fs::metadata(dir.path().join("resources/zeros.bin")).unwrap();
        assert_eq!(unpacked.len(), 2 << 20);
    }

    #[test]
    fn windows_paths_become_drive_and_unc_uris() {
        assert_eq!(
            windows_file_uri(r"C:\Users\Jo Doe\AppData\Local\Temp\fmi2-import-x\resources"),
            "file:///C:/Users/Jo%20Doe/AppData/Local/Temp/fmi2-import-x/resources/"
        );
        assert_eq!(windows_file_uri(r"Z:\"), "file:///Z:/");
        assert_eq!(
            windows_file_uri(r"\\?\D:\fmu\résumé\"),
            "file:///D:/fmu/r%C3%A9sum%C3%A9/"
        );
        assert_eq!(
            windows_file_uri(r"\\server\share\a#b"),
            "file://server/share/a%23b/"
        );
        assert_eq!(
            windows_file_uri(r"\\?\UNC\server\share\x"),
            "file://server/share/x/"
        );
        // Only a letter and a colon make a drive.
        for path in [r"\srv\x", r"ab\c", r"1:\x"] {
            let uri = windows_file_uri(path);
            assert!(!uri["file:".len()..].contains(':'), "{path} became {uri}");
        }
    }

    #[cfg(unix)]
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
