//! A corrupt or hostile `.fmu`: either any bytes, or a small zip archive built from the input
//! (entries named as an FMU names them or not, escaping names, symbolic links, directories,
//! the shipped plant's model description with bytes changed, a real library that is not an
//! FMU, whole or cut short). `Fmu::open` must open it or return an error that names the file;
//! it must not panic, hang or crash, and nothing may be written outside its extraction folder.
//!
//! Run with `TMPDIR` set to an empty folder of its own: the escape check looks beside it.
#![no_main]

use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use fmi2_import::Fmu;
use libfuzzer_sys::arbitrary::{Arbitrary, Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use zip::write::SimpleFileOptions;

/// The name every escaping entry and link target ends in, looked for after each input.
const MARKER: &str = "ckcm-fuzz-escape";

const PLATFORMS: [&str; 4] = ["x86_64-linux", "win64", "darwin64", ""];

fn description() -> &'static [u8] {
    include_bytes!("../../modelDescription/CkcmPlant.xml")
}

/// A shared library that is not an FMU: it loads, and lacks every FMI function.
fn library() -> &'static [u8] {
    static LIB: OnceLock<Vec<u8>> = OnceLock::new();
    LIB.get_or_init(|| {
        [
            "/lib/x86_64-linux-gnu/libm.so.6",
            "/usr/lib/x86_64-linux-gnu/libm.so.6",
        ]
        .iter()
        .find_map(|p| std::fs::read(p).ok())
        .unwrap_or_default()
    })
}

/// Where an escaping entry could land: in the temporary folder that holds the extraction
/// folder, one and two levels above it, and at the root.
fn escape_spots() -> [PathBuf; 4] {
    let tmp = std::env::temp_dir();
    [
        tmp.join(MARKER),
        tmp.join("..").join(MARKER),
        tmp.join("../..").join(MARKER),
        Path::new("/").join(MARKER),
    ]
}

#[derive(Debug)]
enum Content {
    Bytes(Vec<u8>),
    /// The plant's description with up to eight bytes replaced.
    Description(Vec<(u16, u8)>),
    /// The library cut to this fraction (in 1/65536) of its length; 0 keeps it whole.
    Library(u16),
}

#[derive(Debug)]
enum Kind {
    File(Content, bool),
    Dir,
    Symlink(String),
}

#[derive(Debug)]
struct Entry {
    name: String,
    kind: Kind,
}

fn name(u: &mut Unstructured) -> Result<String> {
    let platform = PLATFORMS[usize::from(u.int_in_range(0..=3u8)?)];
    Ok(match u.int_in_range(0..=9u8)? {
        0 => "modelDescription.xml".to_owned(),
        1 => format!("binaries/{platform}/CkcmPlant.so"),
        2 => format!("binaries/{platform}/CkcmPlant.dll"),
        3 => format!("resources/{}", String::arbitrary(u)?),
        4 => format!("../{MARKER}"),
        5 => format!("binaries/{platform}/../../../../{MARKER}"),
        6 => format!("/{MARKER}"),
        7 => "resources/link".to_owned(),
        8 => format!("resources/link/{MARKER}"),
        _ => String::arbitrary(u)?,
    })
}

fn entry(u: &mut Unstructured) -> Result<Entry> {
    let name = name(u)?;
    let kind = match u.int_in_range(0..=5u8)? {
        0 => Kind::Dir,
        1 => Kind::Symlink(if bool::arbitrary(u)? {
            std::env::temp_dir().join("..").display().to_string()
        } else {
            String::arbitrary(u)?
        }),
        k => {
            let content = match k {
                2 => Content::Description(
                    (0..u.int_in_range(0..=8)?)
                        .map(|_| Ok((u16::arbitrary(u)?, u8::arbitrary(u)?)))
                        .collect::<Result<_>>()?,
                ),
                3 => Content::Library(u16::arbitrary(u)?),
                _ => Content::Bytes(Vec::arbitrary(u)?),
            };
            Kind::File(content, bool::arbitrary(u)?)
        }
    };
    Ok(Entry { name, kind })
}

fn bytes_of(content: &Content) -> Vec<u8> {
    match content {
        Content::Bytes(b) => b.clone(),
        Content::Description(edits) => {
            let mut d = description().to_vec();
            for &(at, b) in edits {
                let i = usize::from(at) % d.len();
                d[i] = b;
            }
            d
        }
        Content::Library(0) => library().to_vec(),
        Content::Library(cut) => {
            let lib = library();
            lib[..lib.len() * usize::from(*cut) / 65536].to_vec()
        }
    }
}

/// The archive, or `None` when the zip writer itself refuses an entry (then there is
/// nothing to open).
fn build(entries: &[Entry]) -> Option<Vec<u8>> {
    let mut zip = zip::ZipWriter::new(Cursor::new(Vec::new()));
    for e in entries {
        match &e.kind {
            Kind::Dir => zip.add_directory(e.name.as_str(), SimpleFileOptions::default()),
            Kind::Symlink(target) => zip.add_symlink(
                e.name.as_str(),
                target.as_str(),
                SimpleFileOptions::default(),
            ),
            Kind::File(content, deflate) => {
                let method = if *deflate {
                    zip::CompressionMethod::Deflated
                } else {
                    zip::CompressionMethod::Stored
                };
                let options = SimpleFileOptions::default().compression_method(method);
                zip.start_file(e.name.as_str(), options)
                    .and_then(|()| Ok(zip.write_all(&bytes_of(content))?))
            }
        }
        .ok()?;
    }
    zip.finish().ok().map(Cursor::into_inner)
}

fn archive(data: &[u8]) -> Result<Option<Vec<u8>>> {
    let mut u = Unstructured::new(data);
    if bool::arbitrary(&mut u)? {
        return Ok(Some(u.take_rest().to_vec()));
    }
    let n = u.int_in_range(0..=6)?;
    let entries = (0..n).map(|_| entry(&mut u)).collect::<Result<Vec<_>>>()?;
    Ok(build(&entries))
}

fuzz_target!(|data: &[u8]| {
    let Ok(Some(bytes)) = archive(data) else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("ckcm-fuzz-archive-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("the fuzz folder");
    let path = dir.join("Fuzzed.fmu");
    std::fs::write(&path, &bytes).expect("the fuzzed archive");
    match Fmu::open(&path) {
        Ok(fmu) => drop(fmu),
        Err(e) => {
            let message = e.to_string();
            assert!(
                message.contains(&path.display().to_string()),
                "the error does not name the file: {message}"
            );
        }
    }
    for spot in escape_spots() {
        assert!(
            std::fs::symlink_metadata(&spot).is_err(),
            "an entry escaped the extraction folder: {}",
            spot.display()
        );
    }
});
