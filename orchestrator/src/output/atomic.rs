//! Atomic replacement of a file: write a temporary sibling, make it durable, rename it over the
//! target. Rename within one directory is atomic on POSIX and on NTFS, which is why the
//! temporary file must live next to the target rather than in the system temp directory.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::OutputError;

/// Distinguishes temporary files of concurrent writers within one process (threads writing
/// different trials, or the same file twice).
static NEXT_TEMP: AtomicU64 = AtomicU64::new(0);

/// Writes `path` atomically: creates `<dir>/.<name>.tmp-<pid>-<n>`, calls `write` with a
/// buffered writer on it, flushes and fsyncs it, then renames it over `path`.
///
/// On any error (including a panic inside `write`) the temporary file is removed and the
/// previous content of `path`, if any, is left untouched. Errors name `path`, not the
/// temporary file, because that is the file the user asked for. The new file gets default
/// permissions; those of a replaced file are not carried over.
pub fn write_atomic<F>(path: &Path, write: F) -> Result<(), OutputError>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    prepare_atomic(path, write)?.commit()
}

/// The first half of [`write_atomic`]: the new content, complete and durable under its
/// temporary name, not yet in place. It lets a file be written while something it must not
/// precede (another file's commit) is still under way.
#[must_use = "the file is put in place only by `commit`; dropping it removes the temporary"]
#[derive(Debug)]
pub struct Prepared {
    temp: TempFile,
    path: PathBuf,
}

impl Prepared {
    /// Renames the temporary file over the target and makes the rename durable (nothing to
    /// do for a target written in place, see [`prepare_atomic`]).
    pub fn commit(self) -> Result<(), OutputError> {
        if self.temp.0.is_none() {
            return Ok(());
        }
        let dir = parent_dir(&self.path);
        fs::rename(self.temp.path(), &self.path).map_err(|source| OutputError::Io {
            path: self.path.clone(),
            source,
        })?;
        self.temp.disarm();
        sync_dir(dir);
        Ok(())
    }
}

/// Writes and syncs the temporary file of [`write_atomic`] and stops before the rename.
///
/// Two kinds of target are not replaced by a file of their own: a symbolic link is followed,
/// so the file it names gets the new content and the link stays; and a target that exists
/// but is no regular file (`/dev/null`, `/dev/stdout` on a pipe, a FIFO) is written in
/// place, now, since a rename would put a plain file where the device was (as root, even
/// in `/dev`) and a device has no old content to protect.
pub fn prepare_atomic<F>(path: &Path, write: F) -> Result<Prepared, OutputError>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    let io_error = |source| OutputError::Io {
        path: path.to_owned(),
        source,
    };
    if fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
        let mut out = BufWriter::new(
            OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(io_error)?,
        );
        write(&mut out)
            .and_then(|()| out.flush())
            .map_err(io_error)?;
        return Ok(Prepared {
            temp: TempFile(None),
            path: path.to_owned(),
        });
    }
    let target = match fs::symlink_metadata(path) {
        // A dangling link is replaced, as before: there is no file to follow it to.
        Ok(m) if m.file_type().is_symlink() => {
            fs::canonicalize(path).unwrap_or_else(|_| path.to_owned())
        }
        _ => path.to_owned(),
    };
    let temp = prepare_inner(&target, write).map_err(io_error)?;
    Ok(Prepared { temp, path: target })
}

fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

fn prepare_inner<F>(path: &Path, write: F) -> io::Result<TempFile>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    let name = path
        .file_name()
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "path does not name a file"))?;
    let dir = parent_dir(path);
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(name);
    temp_name.push(format!(
        ".tmp-{}-{}",
        std::process::id(),
        NEXT_TEMP.fetch_add(1, Ordering::Relaxed)
    ));
    let temp_path = dir.join(temp_name);

    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temp_path)?;
    let guard = TempFile(Some(temp_path));

    std::thread::scope(|scope| {
        let mut out = BufWriter::new(EarlySync::new(file, scope));
        write(&mut out)?;
        let early = out.into_inner().map_err(io::IntoInnerError::into_error)?;
        early.finish()?.sync_all()
    })?;
    Ok(guard)
}

/// Bytes written between two early syncs of a large file.
const EARLY_SYNC_BYTES: u64 = 2 << 20;

/// A file whose written data a helper thread syncs every [`EARLY_SYNC_BYTES`] while the
/// writer goes on, so that the final sync of a large file (a recorded trial is about 9 MB of
/// CSV) waits only for the last part: that sync was a third of the time between a campaign's
/// last trial and its end (BENCHMARKS.md, round 16). Small files never start the helper.
struct EarlySync<'scope, 'env> {
    file: File,
    since_sync: u64,
    scope: &'scope std::thread::Scope<'scope, 'env>,
    helper: Helper<'scope>,
}

/// The thread of an [`EarlySync`] file.
enum Helper<'scope> {
    /// Not needed yet: less than [`EARLY_SYNC_BYTES`] written.
    NotStarted,
    /// Asked through the sender; its result says whether every sync succeeded.
    Running(
        std::sync::mpsc::SyncSender<()>,
        std::thread::ScopedJoinHandle<'scope, io::Result<()>>,
    ),
    /// No second handle or no thread could be had: the file goes without early syncs, and
    /// the final sync makes it just as durable.
    Unavailable,
}

impl<'scope, 'env> EarlySync<'scope, 'env> {
    fn new(file: File, scope: &'scope std::thread::Scope<'scope, 'env>) -> Self {
        Self {
            file,
            since_sync: 0,
            scope,
            helper: Helper::NotStarted,
        }
    }

    /// Asks the helper to sync what is written so far; a request still pending covers it.
    fn request_sync(&mut self) {
        if matches!(self.helper, Helper::NotStarted) {
            let (ask, asked) = std::sync::mpsc::sync_channel::<()>(1);
            let started = self.file.try_clone().and_then(|copy| {
                std::thread::Builder::new()
                    .name("early-sync".into())
                    .spawn_scoped(self.scope, move || {
                        while asked.recv().is_ok() {
                            copy.sync_data()?;
                        }
                        Ok(())
                    })
            });
            self.helper = match started {
                Ok(thread) => Helper::Running(ask, thread),
                Err(_) => Helper::Unavailable,
            };
        }
        if let Helper::Running(ask, _) = &self.helper {
            // Full: a sync not yet started will cover these bytes. Disconnected: the helper
            // failed, and `finish` reports why.
            let _ = ask.try_send(());
        }
    }

    /// Waits for the helper and returns the file, or the helper's error: a failed sync is
    /// reported to one file handle only, so it must not be lost with the helper's.
    fn finish(self) -> io::Result<File> {
        if let Helper::Running(ask, thread) = self.helper {
            drop(ask);
            thread
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic))?;
        }
        Ok(self.file)
    }
}

impl Write for EarlySync<'_, '_> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.file.write(buf)?;
        self.since_sync += n as u64;
        if self.since_sync >= EARLY_SYNC_BYTES {
            self.since_sync = 0;
            self.request_sync();
        }
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

/// Makes the rename itself durable. Best effort: the new file is already complete and in
/// place, and some platforms or file systems cannot open or fsync a directory.
fn sync_dir(dir: &Path) {
    if !cfg!(unix) {
        return;
    }
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Removes the temporary file when dropped, unless it was renamed into place. A drop guard
/// (rather than explicit cleanup on each error path) also covers a panicking writer.
#[derive(Debug)]
struct TempFile(Option<PathBuf>);

impl TempFile {
    fn path(&self) -> &Path {
        self.0
            .as_deref()
            .expect("temporary path present until disarmed")
    }

    fn disarm(mut self) {
        self.0 = None;
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if let Some(p) = self.0.take() {
            let _ = fs::remove_file(p);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A FIFO is written in place and stays a FIFO (a rename would have put a plain file
    /// there, as it put one in place of `/dev/full` when run as root); a symbolic link
    /// stays a link, and the file it names gets the content.
    #[cfg(unix)]
    #[test]
    fn special_files_are_written_in_place_and_links_followed() {
        use std::os::unix::fs::FileTypeExt;
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        assert!(made.unwrap().success(), "mkfifo failed");
        // Both ends in threads, the result awaited with a limit: replaced by a rename, the
        // FIFO would leave its reader waiting for a writer that never comes.
        let (done, results) = std::sync::mpsc::channel();
        for writes in [true, false] {
            let (fifo, done) = (fifo.clone(), done.clone());
            std::thread::spawn(move || {
                let got = if writes {
                    write_atomic(&fifo, |w| w.write_all(b"through the pipe"))
                        .map(|()| None)
                        .map_err(|e| e.to_string())
                } else {
                    fs::read(&fifo).map(Some).map_err(|e| e.to_string())
                };
                let _ = done.send(got);
            });
        }
        let mut read = None;
        for _ in 0..2 {
            let got = results
                .recv_timeout(std::time::Duration::from_secs(30))
                .expect("the FIFO's reader or writer hung");
            read = read.or(got.unwrap());
        }
        assert_eq!(read.as_deref(), Some(&b"through the pipe"[..]));
        assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
        assert_eq!(
            dir_entries(dir.path()),
            ["pipe"],
            "a temporary file was left"
        );

        let target = dir.path().join("target.csv");
        fs::write(&target, b"old").unwrap();
        let link = dir.path().join("latest.csv");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_atomic(&link, |w| w.write_all(b"new")).unwrap();
        assert!(
            fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(fs::read(&target).unwrap(), b"new");
    }

    fn dir_entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn writes_content_and_replaces_previous() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        write_atomic(&path, |w| w.write_all(b"first")).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"first");
        write_atomic(&path, |w| w.write_all(b"second")).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        assert_eq!(dir_entries(dir.path()), ["out.txt"]);
    }

    #[test]
    fn failing_writer_keeps_previous_file_and_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("keep.csv");
        fs::write(&path, b"old content").unwrap();
        let err = write_atomic(&path, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("disk on fire"))
        })
        .unwrap_err();
        assert_eq!(fs::read(&path).unwrap(), b"old content");
        assert_eq!(dir_entries(dir.path()), ["keep.csv"]);
        assert_eq!(err.path(), path);
        let msg = err.to_string();
        assert!(msg.contains("keep.csv"), "{msg}");
        let OutputError::Io { source, .. } = err else {
            panic!("expected Io, got {err:?}")
        };
        assert_eq!(source.to_string(), "disk on fire");
    }

    #[test]
    fn panicking_writer_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.txt");
        let result = std::panic::catch_unwind(|| {
            let _ = write_atomic(&path, |w| {
                w.write_all(b"x")?;
                panic!("writer bug")
            });
        });
        assert!(result.is_err());
        assert!(dir_entries(dir.path()).is_empty());
    }

    #[test]
    fn missing_directory_is_an_error_naming_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no-such-dir").join("f.txt");
        let err = write_atomic(&path, |w| w.write_all(b"x")).unwrap_err();
        assert!(err.to_string().contains("f.txt"), "{err}");
    }

    /// A prepared file is complete under its temporary name while the old one stays in
    /// place; commit swaps them, and dropping it instead leaves the old one and no temporary.
    #[test]
    fn prepared_files_appear_only_on_commit() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("memory.csv");
        fs::write(&path, b"old").unwrap();
        let prepared = prepare_atomic(&path, |w| w.write_all(b"new")).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"old");
        let entries = dir_entries(dir.path());
        assert_eq!(entries.len(), 2, "{entries:?}");
        let temp = entries.iter().find(|e| *e != "memory.csv").unwrap();
        assert!(temp.starts_with(".memory.csv.tmp-"), "{temp}");
        assert_eq!(fs::read(dir.path().join(temp)).unwrap(), b"new");
        prepared.commit().unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"new");
        assert_eq!(dir_entries(dir.path()), ["memory.csv"]);

        drop(prepare_atomic(&path, |w| w.write_all(b"dropped")).unwrap());
        assert_eq!(fs::read(&path).unwrap(), b"new");
        assert_eq!(dir_entries(dir.path()), ["memory.csv"]);
    }

    /// A file of several early syncs holds every byte, in order, and leaves no temporary.
    #[test]
    fn a_large_file_is_complete_after_its_early_syncs() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("trial.csv");
        let content: Vec<u8> = (0..7 * EARLY_SYNC_BYTES / 2)
            .map(|i| (i * 7 % 251) as u8)
            .collect();
        write_atomic(&path, |w| {
            for piece in content.chunks(100_003) {
                w.write_all(piece)?;
            }
            Ok(())
        })
        .unwrap();
        assert!(fs::read(&path).unwrap() == content);
        assert_eq!(dir_entries(dir.path()), ["trial.csv"]);
    }

    /// A small file starts no helper; a failed early sync is reported by `finish`, although
    /// the writes after it succeeded (fsync refuses a character device).
    #[cfg(target_os = "linux")]
    #[test]
    fn a_failed_early_sync_is_reported() {
        std::thread::scope(|scope| {
            let null = || OpenOptions::new().write(true).open("/dev/null").unwrap();
            let mut small = EarlySync::new(null(), scope);
            small.write_all(&[0; 1000]).unwrap();
            assert!(matches!(small.helper, Helper::NotStarted));
            small.finish().unwrap();

            let mut large = EarlySync::new(null(), scope);
            let block = vec![0; 1 << 20];
            for _ in 0..3 * EARLY_SYNC_BYTES / (1 << 20) {
                large.write_all(&block).unwrap();
            }
            assert!(matches!(large.helper, Helper::Running(..)));
            let err = large.finish().expect_err("fsync of /dev/null fails");
            assert_eq!(err.kind(), io::ErrorKind::InvalidInput, "{err}");
        });
    }

    #[test]
    fn path_without_file_name_is_rejected() {
        let err = write_atomic(Path::new("/"), |w| w.write_all(b"x")).unwrap_err();
        let OutputError::Io { source, .. } = err else {
            panic!("expected Io, got {err:?}")
        };
        assert_eq!(source.kind(), io::ErrorKind::InvalidInput);
    }

    /// A file named without a folder lies in the current one: its temporary sibling and the
    /// folder synced after the rename are `.`, not the empty path, which opens nothing.
    #[test]
    fn a_bare_file_name_lies_in_the_current_folder() {
        assert_eq!(parent_dir(Path::new("out.csv")), Path::new("."));
        assert_eq!(parent_dir(Path::new("/out.csv")), Path::new("/"));
        assert_eq!(parent_dir(Path::new("a/out.csv")), Path::new("a"));
    }

    /// Only a link is resolved: an existing file keeps the path as written, which is the
    /// one errors name.
    #[test]
    fn an_existing_file_keeps_the_path_as_written() {
        let dir = tempfile::tempdir().unwrap();
        fs::create_dir(dir.path().join("sub")).unwrap();
        fs::write(dir.path().join("x.csv"), "old").unwrap();
        let written = dir.path().join("sub").join("..").join("x.csv");
        let prepared = prepare_atomic(&written, |w| w.write_all(b"new")).unwrap();
        assert_eq!(prepared.path, written);
        prepared.commit().unwrap();
        assert_eq!(fs::read_to_string(dir.path().join("x.csv")).unwrap(), "new");
    }
}
