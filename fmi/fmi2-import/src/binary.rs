//! The check an FMU's shared library passes before it is loaded.
//!
//! The loader maps the file and reads it on demand: a library cut short (an FMU truncated
//! in a download or a copy) loads, and the first read past the file's end kills the whole
//! process with SIGBUS, before any error could be returned. So the file must hold every
//! byte its own headers claim.

use object::{Object, ObjectSection, ObjectSegment};

/// `Err(why)` when `data`, an ELF or PE file, is shorter than its headers say or its
/// headers cannot be read. Other formats are left to the loader, which names them.
pub(crate) fn check_complete(data: &[u8]) -> Result<(), String> {
    let elf_or_pe = data.starts_with(b"\x7fELF") || data.starts_with(b"MZ");
    if !elf_or_pe {
        return Ok(());
    }
    let file =
        object::File::parse(data).map_err(|e| format!("the file is damaged or truncated ({e})"))?;
    let len = data.len() as u64;
    let past_end = |what: String, (offset, size): (u64, u64)| match offset.checked_add(size) {
        Some(end) if end <= len => Ok(()),
        _ => Err(format!(
            "the file is truncated: {what} at bytes {offset}..{} lies past its end \
             ({len} bytes)",
            offset.saturating_add(size)
        )),
    };
    for (i, segment) in file.segments().enumerate() {
        past_end(format!("segment {i}"), segment.file_range())?;
    }
    for section in file.sections() {
        if let Some(range) = section.file_range() {
            let name = section.name().unwrap_or("(unnamed)");
            past_end(format!("section {name}"), range)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// This test binary itself: an ELF or PE file whatever the host.
    fn own_binary() -> Vec<u8> {
        std::fs::read(std::env::current_exe().unwrap()).unwrap()
    }

    #[test]
    fn a_whole_binary_passes() {
        check_complete(&own_binary()).unwrap();
    }

    #[test]
    fn every_cut_of_a_binary_is_refused() {
        let data = own_binary();
        for percent in [1, 10, 33, 50, 90, 99] {
            let cut = &data[..data.len() * percent / 100];
            let err = check_complete(cut).expect_err("a truncated binary passed");
            assert!(
                err.contains("truncated") || err.contains("damaged"),
                "{percent} %: {err}"
            );
        }
        let one_short = &data[..data.len() - 1];
        assert!(check_complete(one_short).is_err());
    }

    /// A file whose headers all lie at its start (a PE file, or an ELF file without a
    /// section table) still parses when cut short: the segments it names must then be found
    /// past its end.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_cut_file_whose_headers_survive_is_refused_by_its_segments() {
        let mut data = own_binary();
        // ELF64: e_shoff at 0x28, e_shnum at 0x3c, e_shstrndx at 0x3e.
        data[0x28..0x30].fill(0);
        data[0x3c..0x40].fill(0);
        check_complete(&data).expect("the file without its section table is whole");
        // One byte short of the last byte a segment loads (debug information, which no
        // segment holds, may follow it).
        let end = object::File::parse(&*data)
            .unwrap()
            .segments()
            .map(|s| s.file_range())
            .map(|(offset, size)| offset + size)
            .max()
            .unwrap();
        let cut = &data[..usize::try_from(end).unwrap() - 1];
        let err = check_complete(cut).expect_err("a truncated binary passed");
        assert!(err.starts_with("the file is truncated: segment "), "{err}");
    }

    #[test]
    fn other_formats_are_left_to_the_loader() {
        assert_eq!(check_complete(b"not an ELF file"), Ok(()));
        assert_eq!(check_complete(b""), Ok(()));
    }
}
