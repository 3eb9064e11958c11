//! FMUs opened once and reused, for a master that runs one campaign after another (a sweep's
//! cases): opening an FMU unpacks and loads it again, and a library's own caches (the CKCM
//! controller's reference table) start empty in every new copy.

use std::path::Path;
use std::time::SystemTime;

use crate::{Fmu, ImportError};

/// A file's size and modification time, to notice that it was replaced.
pub type FileStamp = (u64, Option<SystemTime>);

/// The [`FileStamp`] of the file at `path`, `None` if it cannot be read. [`KeptFmus`] opens
/// again an FMU whose file's stamp changed; a sweep stops if one changes while it runs.
pub fn file_stamp(path: &Path) -> Option<FileStamp> {
    let meta = std::fs::metadata(path).ok()?;
    Some((meta.len(), meta.modified().ok()))
}

/// The FMUs one thread opened, slot by slot, handed out again while they stay usable. Not
/// kept, so opened again on the next request: an FMU that declares
/// `canBeInstantiatedOnlyOncePerProcess` (a second instance of the same library would break
/// that), one whose file changed size or modification time since (the master may fingerprint
/// the file), and all of them after [`KeptFmus::clear`], which a master calls when a run
/// failed (an `fmi2Fatal` concerns every instance of a library). Keep one per thread: FMI 2.0
/// does not promise that a library may be called from two threads.
#[derive(Debug, Default)]
pub struct KeptFmus(Vec<Option<(Fmu, FileStamp)>>);

impl KeptFmus {
    /// The FMU at `path` for `slot`: the one kept there if it came from the same, unchanged
    /// file, else newly opened (and kept, where allowed).
    pub fn open(&mut self, slot: usize, path: &Path) -> Result<Fmu, ImportError> {
        if self.0.len() <= slot {
            self.0.resize(slot + 1, None);
        }
        let now = file_stamp(path);
        if let Some((fmu, _)) = self.0[slot]
            .as_ref()
            .filter(|(kept, then)| kept.path() == path && Some(*then) == now)
        {
            return Ok(fmu.clone());
        }
        let fmu = Fmu::open(path)?;
        let once = fmu
            .model_description()
            .co_simulation
            .as_ref()
            .is_some_and(|cs| cs.can_be_instantiated_only_once_per_process);
        self.0[slot] = now.filter(|_| !once).map(|now| (fmu.clone(), now));
        Ok(fmu)
    }

    /// Drops every kept FMU: the next request for each opens it again.
    pub fn clear(&mut self) {
        self.0.clear();
    }
}
