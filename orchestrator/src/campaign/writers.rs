//! The threads that persist finished trials. Each writes its trial's files as soon as it
//! starts, but commits the trial (summary.csv, progress.toml) only after the writer before
//! it has committed. Several recordings can then be formatted and synced at once (one per
//! lane), while progress.toml still moves forward one trial at a time and never claims a
//! trial whose files are missing.

use std::collections::VecDeque;
use std::sync::mpsc::{Receiver, sync_channel};
use std::thread::{Scope, ScopedJoinHandle};

use super::CampaignError;

/// The writers in flight, oldest first. `T` is what a writer hands back (a recording buffer
/// to reuse).
pub(super) struct Writers<'scope, T> {
    running: VecDeque<ScopedJoinHandle<'scope, Result<Option<T>, CampaignError>>>,
    /// At most this many in flight: each holds a trial's recording.
    most: usize,
    /// Signalled by the newest writer once it has committed; the next one waits for it.
    committed: Option<Receiver<()>>,
    /// The last buffer handed back.
    pub spare: Option<T>,
}

impl<'scope, T: Send + 'scope> Writers<'scope, T> {
    pub fn new(most: usize) -> Self {
        Self {
            running: VecDeque::new(),
            most: most.max(1),
            committed: None,
            spare: None,
        }
    }

    /// Starts the next trial's writer: `files` at once, then `commit` once the writer before
    /// has committed. First waits for the oldest writer while the most are in flight.
    ///
    /// When the writer before fails, `commit` is never called: that writer reports its
    /// error, and this trial's files are leftovers that `--resume` removes.
    pub fn spawn<'env>(
        &mut self,
        scope: &'scope Scope<'scope, 'env>,
        files: impl FnOnce() -> Result<Option<T>, CampaignError> + Send + 'scope,
        commit: impl FnOnce() -> Result<(), CampaignError> + Send + 'scope,
    ) -> Result<(), CampaignError> {
        while self.running.len() >= self.most {
            self.join_oldest()?;
        }
        let before = self.committed.take();
        let (done, waiting) = sync_channel(1);
        self.committed = Some(waiting);
        self.running.push_back(scope.spawn(move || {
            let handed_back = files()?;
            // An error: the writer before dropped its sender without committing.
            if before.is_some_and(|b| b.recv().is_err()) {
                return Ok(handed_back);
            }
            commit()?;
            let _ = done.send(());
            Ok(handed_back)
        }));
        Ok(())
    }

    /// Waits for the oldest writer and keeps what it hands back.
    fn join_oldest(&mut self) -> Result<(), CampaignError> {
        if let Some(writer) = self.running.pop_front() {
            let handed_back = writer
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic))?;
            if handed_back.is_some() {
                self.spare = handed_back;
            }
        }
        Ok(())
    }

    /// Joins the writers that have already finished, oldest first, so that an I/O error
    /// surfaces as early as it would with one writer.
    pub fn reap(&mut self) -> Result<(), CampaignError> {
        while self.running.front().is_some_and(|w| w.is_finished()) {
            self.join_oldest()?;
        }
        Ok(())
    }

    /// Waits for every writer, oldest first; the first error wins.
    pub fn finish(&mut self) -> Result<(), CampaignError> {
        let mut first = Ok(());
        while !self.running.is_empty() {
            let joined = self.join_oldest();
            if first.is_ok() {
                first = joined;
            }
        }
        first
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::time::Duration;

    use super::*;
    use crate::output::OutputError;

    fn failure(k: usize) -> CampaignError {
        CampaignError::Output(OutputError::Io {
            path: PathBuf::from(format!("trial_{k}")),
            source: std::io::Error::other("disk full"),
        })
    }

    /// Later trials' files may be done first (the earlier ones sleep), but the commits come
    /// in trial order, and never more writers than allowed are in flight.
    #[test]
    fn commits_come_in_trial_order_whatever_order_the_files_finish_in() {
        for most in [1, 2, 3] {
            let commits = Mutex::new(Vec::new());
            let (in_flight, peak) = (AtomicUsize::new(0), AtomicUsize::new(0));
            std::thread::scope(|s| {
                let mut writers = Writers::new(most);
                for k in 0..8usize {
                    let (commits, in_flight, peak) = (&commits, &in_flight, &peak);
                    writers
                        .spawn(
                            s,
                            move || {
                                let now = in_flight.fetch_add(1, Ordering::SeqCst) + 1;
                                peak.fetch_max(now, Ordering::SeqCst);
                                std::thread::sleep(Duration::from_millis(((8 - k) * 3) as u64));
                                Ok(Some(k))
                            },
                            move || {
                                commits.lock().unwrap().push(k);
                                in_flight.fetch_sub(1, Ordering::SeqCst);
                                Ok(())
                            },
                        )
                        .unwrap();
                }
                writers.finish().unwrap();
                assert_eq!(writers.spare, Some(7));
            });
            assert_eq!(*commits.lock().unwrap(), (0..8).collect::<Vec<_>>());
            let peak = peak.load(Ordering::SeqCst);
            assert!(
                peak <= most,
                "{peak} writers in flight, at most {most} allowed"
            );
        }
    }

    /// A writer whose files fail reports its error, and no trial after it commits, although
    /// their files were written.
    #[test]
    fn nothing_commits_after_a_failed_writer_and_its_error_is_reported() {
        for failing_in_commit in [false, true] {
            let commits = Mutex::new(Vec::new());
            let files = AtomicUsize::new(0);
            let err = std::thread::scope(|s| {
                let mut writers = Writers::<()>::new(4);
                for k in 0..4usize {
                    let (commits, files) = (&commits, &files);
                    writers
                        .spawn(
                            s,
                            move || {
                                if k == 1 && !failing_in_commit {
                                    return Err(failure(k));
                                }
                                files.fetch_add(1, Ordering::SeqCst);
                                Ok(None)
                            },
                            move || {
                                if k == 1 && failing_in_commit {
                                    return Err(failure(k));
                                }
                                commits.lock().unwrap().push(k);
                                Ok(())
                            },
                        )
                        .unwrap();
                }
                writers.finish().unwrap_err()
            });
            assert!(err.to_string().contains("trial_1"), "{err}");
            assert_eq!(*commits.lock().unwrap(), [0]);
            let written = files.load(Ordering::SeqCst);
            assert_eq!(written, if failing_in_commit { 4 } else { 3 });
        }
    }
}
