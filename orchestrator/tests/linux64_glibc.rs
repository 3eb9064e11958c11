//! The packaged Linux libraries load wherever glibc is 2.17 or newer (RHEL 7, Ubuntu 16.04
//! and every later release): the dynamic loader refuses a library that needs a symbol version
//! its glibc does not define, so none may be newer (`fmu_build::linux64` says how they are
//! linked so).

mod common;

use common::{archive_entry, built_fmu};
use fmu_build::linux64::GLIBC;
use object::read::elf::ElfFile64;

/// Every (library, version) pair the ELF file's version-needs section asks for.
fn needed_versions(elf: &[u8]) -> Vec<(String, String)> {
    let file = ElfFile64::<object::Endianness>::parse(elf).expect("an ELF64 library");
    let endian = file.endian();
    let sections = file.elf_section_table();
    let Some((mut needs, link)) = sections.gnu_verneed(endian, elf).expect("verneed") else {
        return Vec::new();
    };
    let strings = sections
        .strings(endian, elf, link)
        .expect("its string table");
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    let mut found = Vec::new();
    while let Some((need, mut aux)) = needs.next().expect("a version need") {
        let lib = text(need.file(endian, strings).expect("its file name"));
        while let Some(a) = aux.next().expect("a needed version") {
            found.push((
                lib.clone(),
                text(a.name(endian, strings).expect("its name")),
            ));
        }
    }
    found
}

/// `GLIBC_2.14` as (2, 14); None for other version names.
fn glibc_version(name: &str) -> Option<(u32, u32)> {
    let rest = name.strip_prefix("GLIBC_")?;
    let mut parts = rest.split('.').map(|p| p.parse::<u32>().ok());
    Some((parts.next()??, parts.next()?.unwrap_or(0)))
}

#[test]
fn glibc_versions_are_parsed_as_numbers() {
    assert_eq!(glibc_version("GLIBC_2.2.5"), Some((2, 2)));
    assert_eq!(glibc_version("GLIBC_2.17"), Some((2, 17)));
    assert_eq!(glibc_version("GLIBC_2.34"), Some((2, 34)));
    assert_eq!(glibc_version("GLIBC_PRIVATE"), None);
    assert_eq!(glibc_version("GCC_3.0"), None);
    assert!(glibc_version("GLIBC_2.3.4") < glibc_version("GLIBC_2.17"));
}

#[test]
fn the_linux64_libraries_need_no_glibc_newer_than_2_17() {
    let oldest = glibc_version(&format!("GLIBC_{GLIBC}")).unwrap();
    for (fmu, entry) in [
        ("CkcmPlant", "binaries/linux64/CkcmPlant.so"),
        ("HlcsController", "binaries/linux64/HlcsController.so"),
    ] {
        let elf = archive_entry(&built_fmu(fmu), entry);
        let needed = needed_versions(&elf);
        assert!(
            needed.iter().any(|(_, v)| glibc_version(v).is_some()),
            "{fmu}: no glibc version found among {needed:?}; the check would pass vacuously"
        );
        let too_new: Vec<_> = needed
            .iter()
            .filter(|(_, v)| glibc_version(v).is_some_and(|n| n > oldest))
            .collect();
        assert!(
            too_new.is_empty(),
            "{fmu}'s {entry} needs {too_new:?}: it would not load on glibc {GLIBC}"
        );
        assert!(
            !needed.iter().any(|(_, v)| v == "GLIBC_PRIVATE"),
            "{fmu} needs glibc's private symbols, which change with every release"
        );
    }
}
