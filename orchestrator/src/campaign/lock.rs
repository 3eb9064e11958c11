//! An exclusive lock on a campaign folder, so two runs never write into one folder.
//!
//! The lock is an OS advisory lock (`flock` on Unix, `LockFileEx` on Windows, through `fs4`)
//! on `<dir>/.lock`. The kernel releases it when its holder exits, however it exits, so a
//! killed run never leaves the folder locked. The file also names its holder (pid, host,
//! start time) for the message a second run prints. A run that ends normally removes the
//! file; one that was killed leaves it behind, unlocked and harmless.

use std::fs::{self, File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use fs4::fs_std::FileExt;

use super::CampaignError;

/// Name of the lock file inside a campaign folder.
pub const LOCK_FILE: &str = ".lock";

/// Held for the whole run; dropping it releases the lock.
#[derive(Debug)]
pub struct DirLock {
    file: Option<File>,
    path: PathBuf,
    /// The folder, when this run created it (removed again on drop if nothing was written).
    created: Option<PathBuf>,
}

impl DirLock {
    /// Creates `dir` if needed and locks it, or fails naming the run that holds it.
    pub fn acquire(dir: &Path) -> Result<DirLock, CampaignError> {
        let created = (!dir.exists()).then(|| dir.to_path_buf());
        crate::output::create_folder(dir).map_err(|source| CampaignError::CreateDir {
            path: dir.to_path_buf(),
            source,
        })?;
        let path = dir.join(LOCK_FILE);
        let io = |source| CampaignError::Lock {
            path: path.clone(),
            source,
        };
        // A finishing holder removes the file while still holding the lock; whoever opened
        // the old file just before that would lock an orphan. Locking and then checking that
        // the path still names the locked file closes that gap; a few retries suffice.
        for _ in 0..16 {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(io)?;
            if !file.try_lock_exclusive().map_err(io)? {
                let mut holder = String::new();
                let _ = file.read_to_string(&mut holder);
                return Err(CampaignError::Locked {
                    dir: dir.to_path_buf(),
                    holder: describe_holder(&holder),
                });
            }
            if !same_file(&file, &path) {
                continue;
            }
            file.set_len(0).map_err(io)?;
            let since = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs());
            write!(
                file,
                "pid = {}\nhost = {:?}\nsince = {since}\n",
                std::process::id(),
                hostname()
            )
            .map_err(io)?;
            file.flush().map_err(io)?;
            return Ok(DirLock {
                file: Some(file),
                path,
                created,
            });
        }
        Err(io(std::io::Error::other(
            "the lock file keeps being replaced by other runs",
        )))
    }
}

impl Drop for DirLock {
    fn drop(&mut self) {
        // Remove the file while still holding the lock, then release it by closing.
        let _ = fs::remove_file(&self.path);
        drop(self.file.take());
        if let Some(dir) = &self.created {
            // Only succeeds when the run left nothing in the folder it created.
            let _ = fs::remove_dir(dir);
        }
    }
}

/// Whether `path` still names the open `file` (Unix: same device and inode).
#[cfg(unix)]
fn same_file(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// Windows cannot delete an open file, so the path always names the locked file.
#[cfg(not(unix))]
fn same_file(_file: &File, path: &Path) -> bool {
    path.exists()
}

/// `pid 1234 on host "lab-3", since 2025-12-01 00:00:00 UTC`, from the lock file's text
/// (which keeps Unix seconds).
fn describe_holder(text: &str) -> String {
    let field = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key)?.trim_start().strip_prefix('='))
            .map(|v| v.trim().to_owned())
    };
    match (field("pid"), field("host")) {
        (Some(pid), Some(host)) => {
            let since = field("since")
                .map(|s| {
                    let utc = s
                        .parse()
                        .ok()
                        .and_then(|secs| chrono::DateTime::from_timestamp(secs, 0));
                    match utc {
                        Some(t) => format!(", since {}", t.format("%Y-%m-%d %H:%M:%S UTC")),
                        None => format!(", since {s} (Unix time)"),
                    }
                })
                .unwrap_or_default();
            format!("held by pid {pid} on host {host}{since}")
        }
        _ => "held by another run that has not yet written its name".to_owned(),
    }
}

/// This machine's name. Read from the kernel (or `HOSTNAME`) rather than through a crate:
/// it is only shown to users, so a best-effort answer is enough.
fn hostname() -> String {
    ["/proc/sys/kernel/hostname", "/etc/hostname"]
        .iter()
        .find_map(|p| fs::read_to_string(p).ok())
        .map(|s| s.trim().to_owned())
        .filter(|s| !s.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .or_else(|| std::env::var("COMPUTERNAME").ok())
        .unwrap_or_else(|| "unknown".to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_is_refused_naming_the_holder_and_released_on_drop() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("campaign");
        let first = DirLock::acquire(&dir).unwrap();
        let err = DirLock::acquire(&dir).unwrap_err().to_string();
        assert!(
            err.contains(&format!("pid {}", std::process::id())),
            "{err}"
        );
        assert!(err.contains("host"), "{err}");
        drop(first);
        // The folder was created for the lock and is empty: it is gone again.
        assert!(!dir.exists());
        let again = DirLock::acquire(&dir).unwrap();
        fs::write(dir.join("result.csv"), b"x").unwrap();
        drop(again);
        assert!(dir.join("result.csv").exists());
        assert!(!dir.join(LOCK_FILE).exists());
    }

    #[test]
    fn the_holder_is_named_with_its_start_as_a_utc_date() {
        let text = "pid = 42\nhost = \"lab-3\"\nsince = 1764547200\n";
        assert_eq!(
            describe_holder(text),
            "held by pid 42 on host \"lab-3\", since 2025-12-01 00:00:00 UTC"
        );
        // A value that is no time is shown as written.
        let odd = "pid = 42\nhost = \"lab-3\"\nsince = soon\n";
        assert_eq!(
            describe_holder(odd),
            "held by pid 42 on host \"lab-3\", since soon (Unix time)"
        );
    }

    #[test]
    fn a_stale_lock_file_of_a_killed_run_does_not_block() {
        let tmp = tempfile::tempdir().unwrap();
        fs::write(
            tmp.path().join(LOCK_FILE),
            "pid = 999999\nhost = \"x\"\nsince = 0\n",
        )
        .unwrap();
        let lock = DirLock::acquire(tmp.path()).unwrap();
        let text = fs::read_to_string(tmp.path().join(LOCK_FILE)).unwrap();
        assert!(
            text.contains(&format!("pid = {}", std::process::id())),
            "{text}"
        );
        drop(lock);
    }

    /// The check that closes the race with a finishing holder: a lock taken on a file that
    /// was removed and made again under the same name is on an orphan, and must not count.
    #[cfg(unix)]
    #[test]
    fn a_file_replaced_under_its_name_is_not_the_same_file() {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join(LOCK_FILE);
        fs::write(&path, "old").unwrap();
        let opened = File::open(&path).unwrap();
        assert!(same_file(&opened, &path));
        // The old file stays open, so the new one cannot reuse its inode.
        fs::remove_file(&path).unwrap();
        fs::write(&path, "new").unwrap();
        assert!(!same_file(&opened, &path));
        // Another file on the same device is not it either, nor is a path that names nothing.
        let other = File::open(tmp.path()).unwrap();
        assert!(!same_file(&other, &path));
        fs::remove_file(&path).unwrap();
        assert!(!same_file(&opened, &path));
    }

    /// The message names the machine as the kernel does, so that a user on a cluster can
    /// find the run that holds the folder.
    #[cfg(target_os = "linux")]
    #[test]
    fn the_holder_is_named_by_this_machines_host_name() {
        let kernel = fs::read_to_string("/proc/sys/kernel/hostname").unwrap();
        let kernel = kernel.trim();
        assert!(!kernel.is_empty());
        let tmp = tempfile::tempdir().unwrap();
        let _first = DirLock::acquire(tmp.path()).unwrap();
        let err = DirLock::acquire(tmp.path()).unwrap_err().to_string();
        assert!(
            err.contains(&format!("on host {kernel:?}, since ")),
            "{err}"
        );
    }
}
