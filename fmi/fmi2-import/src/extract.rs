//! Folders FMUs are unpacked into, and their clean-up when a process ends abnormally.
//!
//! Each folder is `<temp>/fmi2-import-<pid>-<random>`: the pid marks its owner. A folder
//! is removed when the last user of its FMU is dropped; [`remove_extraction_dirs`] removes
//! the live ones from a signal handler (which then exits without running destructors); and
//! the first FMU a process opens reaps folders whose owner is no longer running, left by
//! runs that were killed with SIGKILL or crashed.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, Once, PoisonError};

use tempfile::TempDir;

/// Prefix of every extraction folder, followed by `<pid>-`.
pub const EXTRACTION_PREFIX: &str = "fmi2-import-";

/// Folders of this process that are alive now.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
static REAP: Once = Once::new();

/// An extraction folder, registered while it exists.
#[derive(Debug)]
pub(crate) struct ExtractionDir(TempDir);

impl ExtractionDir {
    /// Creates a new folder in the system temp directory (after reaping stale ones once).
    pub(crate) fn new() -> std::io::Result<ExtractionDir> {
        REAP.call_once(|| {
            reap_stale_extraction_dirs(&std::env::temp_dir());
        });
        // The list is held while the folder is made, so that a signal handler's
        // `remove_extraction_dirs` sees every folder that exists: made before the lock,
        // one could appear between its removals and the exit, and stay behind.
        let mut live = LIVE.lock().unwrap_or_else(PoisonError::into_inner);
        let dir = tempfile::Builder::new()
            .prefix(&format!("{EXTRACTION_PREFIX}{}-", std::process::id()))
            .tempdir()?;
        live.push(dir.path().to_path_buf());
        Ok(ExtractionDir(dir))
    }

    pub(crate) fn path(&self) -> &Path {
        self.0.path()
    }
}

impl Drop for ExtractionDir {
    fn drop(&mut self) {
        let mut live = LIVE.lock().unwrap_or_else(PoisonError::into_inner);
        live.retain(|p| p != self.0.path());
        // The TempDir field then removes the folder.
    }
}

/// Removes every extraction folder of this process now, for a signal handler that is about
/// to exit the process (the FMUs' libraries stay mapped; nothing reads the files again).
/// Returns how many folders were removed.
///
/// The list stays locked until the process ends, so no other thread makes a folder after
/// these are gone: opening an FMU, or dropping one, blocks from here on.
pub fn remove_extraction_dirs() -> usize {
    let live = LIVE.lock().unwrap_or_else(PoisonError::into_inner);
    let removed = live
        .iter()
        .filter(|p| std::fs::remove_dir_all(p).is_ok())
        .count();
    std::mem::forget(live);
    removed
}

/// Removes extraction folders in `temp` whose owning process is no longer running; returns
/// how many. Folders of running processes (including this one) and anything not named like
/// an extraction folder are left alone.
pub fn reap_stale_extraction_dirs(temp: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(temp) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.filter_map(Result::ok) {
        let name = entry.file_name();
        let Some(pid) = name
            .to_str()
            .and_then(|n| n.strip_prefix(EXTRACTION_PREFIX))
            .and_then(|rest| rest.split_once('-'))
            .and_then(|(pid, _)| pid.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id()
            && process_is_gone(pid)
            && entry.file_type().is_ok_and(|t| t.is_dir())
            && std::fs::remove_dir_all(entry.path()).is_ok()
        {
            removed += 1;
        }
    }
    removed
}

/// Whether no process `pid` exists (a process of another user still counts as running).
#[cfg(unix)]
fn process_is_gone(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    if pid <= 0 {
        return false;
    }
    // SAFETY: kill with signal 0 sends nothing; it only checks that the pid exists and may
    // be signalled. It has no memory-safety preconditions.
    let r = unsafe { libc::kill(pid, 0) };
    r != 0 && std::io::Error::last_os_error().raw_os_error() == Some(libc::ESRCH)
}

/// Without a portable check, never reap.
#[cfg(not(unix))]
fn process_is_gone(_pid: u32) -> bool {
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reaps_folders_of_dead_processes_only() {
        let temp = tempfile::tempdir().unwrap();
        // A pid that existed and has exited (and was reaped by wait).
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let stale = temp.path().join(format!("{EXTRACTION_PREFIX}{dead}-abc"));
        let mine = temp
            .path()
            .join(format!("{EXTRACTION_PREFIX}{}-abc", std::process::id()));
        let other = temp.path().join("fmi2-import-notapid-abc");
        for d in [&stale, &mine, &other] {
            std::fs::create_dir(d).unwrap();
            std::fs::write(d.join("f"), b"x").unwrap();
        }
        assert_eq!(reap_stale_extraction_dirs(temp.path()), 1);
        assert!(!stale.exists());
        assert!(mine.exists() && other.exists());
    }

    /// Another process's folder is reaped only once that process has exited: a second
    /// master running beside this one keeps its FMUs.
    #[cfg(unix)]
    #[test]
    fn a_running_process_is_not_gone() {
        let mut exited = std::process::Command::new("true").spawn().unwrap();
        let dead = exited.id();
        exited.wait().unwrap();
        let mut running = std::process::Command::new("sleep")
            .arg("30")
            .spawn()
            .unwrap();
        // The exited one first: its check leaves ESRCH in errno, which the running one's
        // successful check must not read.
        let gone = (process_is_gone(dead), process_is_gone(running.id()));
        let temp = tempfile::tempdir().unwrap();
        let theirs = temp
            .path()
            .join(format!("{EXTRACTION_PREFIX}{}-abc", running.id()));
        std::fs::create_dir(&theirs).unwrap();
        let reaped = reap_stale_extraction_dirs(temp.path());
        running.kill().unwrap();
        running.wait().unwrap();
        assert_eq!(gone, (true, false));
        assert_eq!(reaped, 0);
        assert!(theirs.exists());
    }

    #[test]
    fn live_folders_are_registered_until_dropped() {
        let dir = ExtractionDir::new().unwrap();
        let path = dir.path().to_path_buf();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            name.starts_with(&format!("{EXTRACTION_PREFIX}{}-", std::process::id())),
            "{name}"
        );
        assert!(LIVE.lock().unwrap().contains(&path));
        drop(dir);
        assert!(!path.exists());
        assert!(!LIVE.lock().unwrap().contains(&path));
    }
}
