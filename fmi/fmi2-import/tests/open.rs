//! `Fmu::open` errors that need no working FMU binary: each names the file and the problem.

use std::path::{Path, PathBuf};

use fmi2_import::{Fmu, ImportError, PLATFORM, SHARED_LIBRARY_EXTENSION};
use fmi2_md::MdErrorKind;
use fmu_build::write_fmu;

const VALID: &str = include_str!("../../fmi2-md/tests/fixtures/valid.xml");

fn temp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

fn open_err(path: &Path) -> ImportError {
    match Fmu::open(path) {
        Ok(_) => panic!("{} opened", path.display()),
        Err(e) => e,
    }
}

/// An archive with this description, no binary.
fn fmu_with(dir: &Path, xml: &str) -> PathBuf {
    let path = dir.join("Model.fmu");
    write_fmu(&path, xml, None, &[]).unwrap();
    path
}

#[test]
fn missing_file_is_named() {
    let err = open_err(Path::new("/nonexistent/Missing.fmu"));
    assert!(!err.is_binary_problem(), "no FMU at all");
    assert!(matches!(err, ImportError::NotFound { .. }), "{err:?}");
    assert_eq!(err.to_string(), "/nonexistent/Missing.fmu: no such file");
}

/// A file that is no zip archive is named with what it is, where its first bytes tell: the
/// model's library, its description alone, text, an empty file, a cut archive.
#[test]
fn not_a_zip_says_what_the_file_is() {
    let dir = temp();
    let valid = fmu_with(dir.path(), VALID);
    let archive = std::fs::read(&valid).unwrap();
    let mut elf = b"\x7fELF\x02\x01\x01".to_vec();
    elf.resize(4096, 0);
    let mut dll = b"MZ\x90\x00".to_vec();
    dll.resize(4096, 0xff);
    // A text longer than the bytes read, cut inside a two-byte character at byte 1024.
    let long_text = format!("{}é and more", "x".repeat(1023));
    let mut macho = vec![0xcf, 0xfa, 0xed, 0xfe, 7, 0, 0, 1];
    macho.resize(4096, 0);
    let cases: [(&str, Vec<u8>, &str); 11] = [
        ("Empty.fmu", Vec::new(), "the file is empty"),
        (
            "lib.so",
            elf,
            "it is an ELF shared library or program; an FMU is a zip archive",
        ),
        ("Model.dll", dll, "it is a Windows DLL or program; "),
        (
            "md.xml",
            format!("\u{feff}  {VALID}").into_bytes(),
            "it is XML text (a modelDescription.xml alone?); ",
        ),
        (
            "notes.fmu",
            b"this is not a zip archive at all".to_vec(),
            "it is a text file; ",
        ),
        ("long.fmu", long_text.into_bytes(), "it is a text file; "),
        (
            "Model.tar.gz",
            vec![0x1f, 0x8b, 8, 0, 0, 0, 0, 0],
            "it is gzip-compressed (a .tar.gz?); ",
        ),
        (
            "Cut.fmu",
            archive[..archive.len() / 2].to_vec(),
            "it begins like one but is damaged or cut short: ",
        ),
        (
            "Noise.fmu",
            vec![0x00, 0x9c, 0xff, 0x13, 0x37, 0x00, 0xfe],
            "the zip reader says: ",
        ),
        ("lib.dylib", macho, "it is a macOS library or program; "),
        // Text at first, then a byte no UTF-8 text has, well inside the bytes read: not
        // a text file.
        (
            "Mixed.fmu",
            b"looks like text\xff\xfe\x01 but is not".to_vec(),
            "the zip reader says: ",
        ),
    ];
    for (name, bytes, detail) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let err = open_err(&path);
        assert!(matches!(err, ImportError::NotZip { .. }), "{name}: {err:?}");
        let expected = format!("{} is not a zip archive: {detail}", path.display());
        assert!(err.to_string().starts_with(&expected), "{name}: {err}");
    }
}

/// A named pipe or a device given as an FMU is refused at once: opening a pipe would wait
/// for a writer, and a device such as /dev/zero never ends.
#[cfg(unix)]
#[test]
fn a_pipe_or_device_is_refused_without_reading_it() {
    let dir = temp();
    let fifo = dir.path().join("pipe.fmu");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success());
    for (path, kind) in [
        (fifo.as_path(), "a named pipe (FIFO)"),
        (Path::new("/dev/zero"), "a device"),
    ] {
        let err = open_err(path);
        assert_eq!(
            err.to_string(),
            format!(
                "{} is not a zip archive: it is {kind}; an FMU is a regular file the reader can \
                 seek in",
                path.display()
            )
        );
    }
}

/// A folder, unpacked FMU or not, is named as a folder rather than as a damaged archive.
#[test]
fn a_folder_is_named_as_one() {
    let dir = temp();
    let plain = dir.path().join("Plain.fmu");
    std::fs::create_dir(&plain).unwrap();
    let err = open_err(&plain);
    assert!(
        matches!(
            err,
            ImportError::Folder {
                unpacked: false,
                ..
            }
        ),
        "{err:?}"
    );
    assert_eq!(
        err.to_string(),
        format!(
            "{} is a folder, not an .fmu file: an FMU is one zip archive",
            plain.display()
        )
    );
    let unpacked = dir.path().join("Unpacked");
    std::fs::create_dir(&unpacked).unwrap();
    std::fs::write(
        unpacked.join("modelDescription.xml"),
        "<fmiModelDescription/>",
    )
    .unwrap();
    let err = open_err(&unpacked);
    assert!(
        err.to_string()
            .contains("holds an unpacked FMU's modelDescription.xml"),
        "{err}"
    );
}

#[test]
fn zip_without_model_description() {
    let dir = temp();
    let path = dir.path().join("Empty.fmu");
    let mut zip = zip::ZipWriter::new(std::fs::File::create(&path).unwrap());
    zip.start_file(
        "documentation/index.html",
        zip::write::SimpleFileOptions::default(),
    )
    .unwrap();
    std::io::Write::write_all(&mut zip, b"<html/>").unwrap();
    zip.finish().unwrap();
    let err = open_err(&path);
    assert!(
        matches!(err, ImportError::NoModelDescription { .. }),
        "{err:?}"
    );
    assert_eq!(
        err.to_string(),
        format!(
            "{} contains no modelDescription.xml at the archive root",
            path.display()
        )
    );
}

#[test]
fn fmi1_description() {
    let dir = temp();
    let path = fmu_with(
        dir.path(),
        &VALID.replacen("fmiVersion=\"2.0\"", "fmiVersion=\"1.0\"", 1),
    );
    let err = open_err(&path);
    match &err {
        ImportError::ModelDescription { source, .. } => {
            assert_eq!(*source.kind, MdErrorKind::Fmi1("1.0".into()))
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        err.to_string(),
        format!(
            "{}: modelDescription.xml:3: FMI 1.0 model descriptions are not supported (fmiVersion=\"1.0\")",
            path.display()
        )
    );
}

#[test]
fn model_exchange_only_description() {
    let dir = temp();
    let path = fmu_with(
        dir.path(),
        &VALID.replacen("<CoSimulation", "<ModelExchange", 1),
    );
    let err = open_err(&path);
    assert!(
        err.to_string()
            .ends_with("no <CoSimulation> element: this FMU is Model Exchange only"),
        "{err}"
    );
}

#[test]
fn malformed_description_reports_its_line() {
    let dir = temp();
    let path = fmu_with(
        dir.path(),
        &VALID.replacen("</ModelVariables>", "</ModelVariable>", 1),
    );
    let err = open_err(&path);
    let line = VALID
        .lines()
        .position(|l| l.contains("</ModelVariables>"))
        .unwrap()
        + 1;
    let text = err.to_string();
    assert!(
        text.starts_with(&format!(
            "{}: modelDescription.xml:{line}: malformed XML",
            path.display()
        )),
        "{text}"
    );
}

#[test]
fn invalid_description_lists_every_problem() {
    let dir = temp();
    let xml = VALID
        .replacen("2026-11-23T12:00:00Z", "yesterday", 1)
        .replacen("stepSize=\"0.001\"", "stepSize=\"0\"", 1);
    let err = open_err(&fmu_with(dir.path(), &xml));
    match &err {
        ImportError::InvalidModelDescription { problems, .. } => {
            assert_eq!(problems.len(), 2, "{problems:#?}")
        }
        other => panic!("{other:?}"),
    }
    let text = err.to_string();
    assert!(
        text.contains("modelDescription.xml has 2 problem(s):"),
        "{text}"
    );
    assert!(
        text.contains("\n  - fmiModelDescription: generationDateAndTime 'yesterday'"),
        "{text}"
    );
    assert!(
        text.contains("\n  - DefaultExperiment: stepSize must be > 0, is 0"),
        "{text}"
    );
}

#[test]
fn missing_binary_names_the_expected_path() {
    let dir = temp();
    let err = open_err(&fmu_with(dir.path(), VALID));
    assert!(matches!(err, ImportError::MissingBinary { .. }), "{err:?}");
    assert!(err.is_binary_problem(), "a sound FMU that cannot run here");
    let expected = format!("binaries/{PLATFORM}/MiniPlatform.{SHARED_LIBRARY_EXTENSION}");
    assert!(
        err.to_string().ends_with(&format!(
            "no binary for this platform ({PLATFORM}): expected {expected} inside the archive; \
             the archive has no binaries for any platform"
        )),
        "{err}"
    );
}

#[test]
fn missing_binary_lists_the_platforms_the_archive_has() {
    let dir = temp();
    let path = dir.path().join("Elsewhere.fmu");
    write_fmu(
        &path,
        VALID,
        None,
        &[
            ("binaries/win32/MiniPlatform.dll", b"MZ"),
            ("binaries/darwin64/MiniPlatform.dylib", b"x"),
        ],
    )
    .unwrap();
    let err = open_err(&path);
    assert!(
        matches!(&err, ImportError::MissingBinary { platform, available, .. }
            if *platform == PLATFORM && available == &["darwin64", "win32"]),
        "{err:?}"
    );
    assert!(
        err.to_string().ends_with(&format!(
            "expected binaries/{PLATFORM}/MiniPlatform.{SHARED_LIBRARY_EXTENSION} inside the \
             archive; the archive has binaries for darwin64, win32"
        )),
        "{err}"
    );
}

#[test]
fn binary_that_is_not_a_library_fails_to_load() {
    let dir = temp();
    let fake = dir.path().join("fake.so");
    std::fs::write(&fake, b"not an ELF file").unwrap();
    let path = dir.path().join("Fake.fmu");
    write_fmu(&path, VALID, Some(&fake), &[("resources/data.txt", b"x")]).unwrap();
    let err = open_err(&path);
    assert!(matches!(err, ImportError::Load { .. }), "{err:?}");
    assert!(err.is_binary_problem());
    // The .fmu, the binary inside it and the loader's own reason; no temporary path.
    let text = err.to_string();
    let binary = format!("binaries/{PLATFORM}/MiniPlatform.so");
    assert!(
        text.starts_with(&format!(
            "{}: cannot load its binary {binary}: ",
            path.display()
        )),
        "{text}"
    );
    assert!(
        text.contains(&format!("{binary}: file too short")),
        "{text}"
    );
    assert!(!text.contains("fmi2-import-"), "{text}");
}

/// A stand-in shared library without FMI functions: the C runtime's libm, always present.
fn libm() -> &'static Path {
    [
        "/lib/x86_64-linux-gnu/libm.so.6",
        "/usr/lib/x86_64-linux-gnu/libm.so.6",
        "/lib64/libm.so.6",
    ]
    .iter()
    .map(Path::new)
    .find(|p| p.exists())
    .expect("no libm.so.6 found to stand in for a non-FMU library")
}

#[test]
fn a_truncated_binary_is_refused_before_it_is_loaded() {
    // Loaded, a library cut short is mapped, and the first read past its end kills the
    // process with SIGBUS; this test would then crash rather than fail.
    let whole = std::fs::read(libm()).unwrap();
    let dir = temp();
    for percent in [10, 33, 90] {
        let cut = dir.path().join(format!("cut{percent}.so"));
        std::fs::write(&cut, &whole[..whole.len() * percent / 100]).unwrap();
        let path = dir.path().join(format!("Cut{percent}.fmu"));
        write_fmu(&path, VALID, Some(&cut), &[]).unwrap();
        let err = open_err(&path);
        assert!(matches!(err, ImportError::Load { .. }), "{err:?}");
        let text = err.to_string();
        assert!(
            text.contains(&format!(
                "cannot load its binary binaries/{PLATFORM}/MiniPlatform.so: the file is"
            )) && (text.contains("truncated") || text.contains("damaged")),
            "{percent} %: {text}"
        );
    }
}

#[test]
fn library_without_fmi_functions_names_the_first_missing_symbol() {
    let dir = temp();
    let path = dir.path().join("Libm.fmu");
    write_fmu(&path, VALID, Some(libm()), &[]).unwrap();
    let err = open_err(&path);
    match &err {
        ImportError::MissingSymbol { symbol, .. } => assert_eq!(*symbol, "fmi2GetTypesPlatform"),
        other => panic!("{other:?}"),
    }
    assert!(
        err.to_string().contains(&format!(
            "its binary binaries/{PLATFORM}/MiniPlatform.so lacks the FMI 2.0 function \
             fmi2GetTypesPlatform: dlsym failed: "
        )),
        "{err}"
    );
}
