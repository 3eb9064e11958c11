//! Trials at once: with the plain memory update (u_{k+1} = m_k), trial k+1 needs at step n
//! only what trial k wrote at step n. N lanes, each a thread with its own FMU instances, run
//! the trials in turn (lane i the trials first + i mod N), in a ring: trial k+1 follows
//! trial k a chunk of [`CHUNK_STEPS`](crate::master::CHUNK_STEPS) steps behind, receiving
//! m_k chunk by chunk. Every trial computes exactly what it computes alone, so results do
//! not depend on N.
//!
//! The campaign takes the outcomes in trial order and persists them as it does for a single
//! lane. A lane that fails stops; the trials after it are cancelled, never reported, because
//! the campaign stops at the first failed trial.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, SyncSender, sync_channel};

use fmi2_import::Fmu;

use super::{CampaignError, TrialSummary};
use crate::master::{CHUNK_STEPS, FmuConsole, Master, MasterError, MemoryLink, Stopped};
use crate::output::RecordedRows;
use crate::scenario::Scenario;

/// What a lane hands the campaign for one successful trial.
pub(super) struct Finished {
    pub summary: TrialSummary,
    pub recording: Option<RecordedRows>,
    /// The memory this trial wrote (read by the next), channel by channel.
    pub memory: Vec<Vec<f64>>,
}

/// What a lane hands the campaign for a failed trial: why, and its recording up to the
/// failure (if the trial was recorded), which the campaign keeps beside the completed trials.
pub(super) struct Failed {
    pub error: MasterError,
    pub recording: Option<RecordedRows>,
}

impl From<MasterError> for Box<Failed> {
    fn from(error: MasterError) -> Self {
        Box::new(Failed {
            error,
            recording: None,
        })
    }
}

enum Report {
    /// The lane's master is set up (or why it is not).
    Ready(Result<(), CampaignError>),
    Trial(usize, Result<Box<Finished>, Box<Failed>>),
}

/// One chunk of one channel's memory.
struct Chunk {
    trial: usize,
    channel: usize,
    index: usize,
    data: Vec<f64>,
}

/// The ends of the link from the trial before (inbound) and to the trial after (outbound),
/// with the emptied chunk buffers going back the other way so that steady running
/// allocates nothing.
struct Link<'a> {
    trial: usize,
    receives: bool,
    sends: bool,
    inbound: &'a Receiver<Chunk>,
    outbound: &'a SyncSender<Chunk>,
    returned: &'a Receiver<Vec<f64>>,
    give_back: &'a SyncSender<Vec<f64>>,
    abort: &'a AtomicBool,
}

impl MemoryLink for Link<'_> {
    const ACTIVE: bool = true;

    fn receive(&mut self, c: usize, chunk: usize, read: &mut [f64]) -> Result<(), Stopped> {
        if self.abort.load(Ordering::Relaxed) {
            return Err(Stopped);
        }
        if !self.receives {
            return Ok(());
        }
        // Disconnected: the lane of the trial before stopped.
        let got = self.inbound.recv().map_err(|_| Stopped)?;
        debug_assert_eq!(
            (got.trial + 1, got.channel, got.index),
            (self.trial, c, chunk)
        );
        read.copy_from_slice(&got.data);
        // Full only if the other lane stopped; the buffer is then simply dropped.
        let _ = self.give_back.try_send(got.data);
        Ok(())
    }

    fn send(&mut self, c: usize, chunk: usize, written: &[f64]) {
        if !self.sends {
            return;
        }
        let mut data = self.returned.try_recv().unwrap_or_default();
        data.clear();
        data.extend_from_slice(written);
        // An error means the next trial's lane has stopped: nobody needs the chunk.
        let _ = self.outbound.send(Chunk {
            trial: self.trial,
            channel: c,
            index: chunk,
            data,
        });
    }
}

/// Everything a lane needs besides its own FMUs and link ends.
struct Shared<'a> {
    scenario: &'a Scenario,
    logging: bool,
    first: usize,
    last: usize,
    lanes: usize,
    abort: &'a AtomicBool,
    /// Where every lane's master shows its FMUs' messages, and its bar counts the steps.
    console: FmuConsole,
}

struct Ends {
    inbound: Receiver<Chunk>,
    outbound: SyncSender<Chunk>,
    returned: Receiver<Vec<f64>>,
    give_back: SyncSender<Vec<f64>>,
}

/// Another copy of every FMU of `scenario`, each unpacked and loaded on its own (as a
/// sweep's cases are), so that no instance or library state is shared between lanes.
fn open_copies(scenario: &Scenario) -> Result<Vec<Fmu>, CampaignError> {
    scenario
        .fmus
        .iter()
        .map(|f| {
            Fmu::open(&f.path).map_err(|e| CampaignError::SecondCopy {
                fmu: f.name.clone(),
                path: f.path.clone(),
                source: Box::new(e),
            })
        })
        .collect()
}

/// Runs trials `first + i, first + i + lanes, …` below `last` on FMUs `fmus`, or on copies
/// it opens itself.
fn lane(
    sh: &Shared<'_>,
    i: usize,
    fmus: Option<Vec<Fmu>>,
    initial: Option<&[Vec<f64>]>,
    ends: Ends,
    reports: Sender<Report>,
) {
    let set_up = fmus
        .map_or_else(|| open_copies(sh.scenario), Ok)
        .and_then(|fmus| Ok(Master::new(sh.scenario, fmus, sh.logging)?))
        .map(|mut master| {
            master.set_console(sh.console.clone());
            master
        });
    let mut master = match set_up {
        Ok(m) => m,
        Err(e) => {
            let _ = reports.send(Report::Ready(Err(e)));
            return;
        }
    };
    if let Some(data) = initial {
        master.set_memory(data);
    }
    let _ = reports.send(Report::Ready(Ok(())));
    let mut signals = master.new_signals();
    for k in (sh.first + i..sh.last).step_by(sh.lanes) {
        if sh.abort.load(Ordering::Relaxed) {
            return;
        }
        let mut recording = sh
            .scenario
            .record
            .records_trial(k)
            .then(|| master.new_recording());
        let mut link = Link {
            trial: k,
            receives: k > sh.first,
            sends: k + 1 < sh.last,
            inbound: &ends.inbound,
            outbound: &ends.outbound,
            returned: &ends.returned,
            give_back: &ends.give_back,
            abort: sh.abort,
        };
        let ran = master.run_trial_linked(
            k,
            recording.as_mut(),
            &mut signals,
            |n| {
                if n % 1000 == 999 {
                    sh.console.bar().inc(1000);
                }
            },
            &mut link,
        );
        let failed = ran.is_err();
        let outcome = match ran {
            Ok(()) => Ok(Box::new(Finished {
                summary: TrialSummary::compute(k, sh.scenario, &signals),
                recording,
                memory: master.memory().iter().map(|m| m.to_vec()).collect(),
            })),
            Err(error) => Err(Box::new(Failed { error, recording })),
        };
        if reports.send(Report::Trial(k, outcome)).is_err() || failed {
            return;
        }
    }
}

/// The campaign's side of the running lanes.
pub(super) struct Lanes {
    reports: Receiver<Report>,
    early: BTreeMap<usize, Result<Box<Finished>, Box<Failed>>>,
}

impl Lanes {
    /// Starts `n` lanes for trials `first..last` in `scope`: lane i runs the trials
    /// `first + i (mod n)`, the first on `fmus`, the others on copies they open, in a ring
    /// where lane i hands its memory to lane i + 1. `initial` is the memory trial `first`
    /// reads (on resume). Every lane counts its steps on `console`'s bar and shows its FMUs'
    /// messages through (a clone of) it. Returns once every lane has set up its instances.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn start<'scope, 'env: 'scope>(
        scope: &'scope std::thread::Scope<'scope, 'env>,
        scenario: &'env Scenario,
        fmus: Vec<Fmu>,
        n: usize,
        logging: bool,
        (first, last): (usize, usize),
        initial: Option<&'env [Vec<f64>]>,
        console: &FmuConsole,
        abort: &'env AtomicBool,
    ) -> Result<Self, CampaignError> {
        // Lane i starts trial k + n only after lane i + 1, running trial k + 1, has taken
        // chunk j of trial k; so a link holds at most one trial's chunks plus one. Twice that
        // can never fill, so a send never waits.
        let chunks = scenario.steps.div_ceil(CHUNK_STEPS);
        let bound = (2 * chunks + 2) * scenario.memory.len().max(1);
        // Link i: lane i's memory to lane i + 1, and the emptied buffers back.
        let mut to_next: Vec<Option<SyncSender<Chunk>>> = Vec::with_capacity(n);
        let mut from_prev: Vec<Option<Receiver<Chunk>>> = Vec::with_capacity(n);
        let mut give_back: Vec<Option<SyncSender<Vec<f64>>>> = Vec::with_capacity(n);
        let mut returned: Vec<Option<Receiver<Vec<f64>>>> = Vec::with_capacity(n);
        for _ in 0..n {
            let (tx, rx) = sync_channel::<Chunk>(bound);
            to_next.push(Some(tx));
            from_prev.push(Some(rx));
            let (tx, rx) = sync_channel::<Vec<f64>>(bound);
            give_back.push(Some(tx));
            returned.push(Some(rx));
        }
        let (tx, reports) = std::sync::mpsc::channel();
        let mut fmus = Some(fmus);
        for i in 0..n {
            let prev = (i + n - 1) % n;
            let ends = Ends {
                inbound: from_prev[prev].take().expect("each link has one consumer"),
                outbound: to_next[i].take().expect("each link has one producer"),
                returned: returned[i].take().expect("each link has one producer"),
                give_back: give_back[prev].take().expect("each link has one consumer"),
            };
            let sh = Shared {
                scenario,
                logging,
                first,
                last,
                lanes: n,
                abort,
                console: console.clone(),
            };
            let tx = tx.clone();
            let (own, initial) = if i == 0 {
                (fmus.take(), initial)
            } else {
                (None, None)
            };
            scope.spawn(move || lane(&sh, i, own, initial, ends, tx));
        }
        drop(tx);
        let mut lanes = Self {
            reports,
            early: BTreeMap::new(),
        };
        let mut ready = 0;
        let mut failure = None;
        while ready < n {
            match lanes.reports.recv() {
                Ok(Report::Ready(r)) => {
                    ready += 1;
                    if let Err(e) = r {
                        failure.get_or_insert(e);
                    }
                }
                Ok(Report::Trial(k, r)) => {
                    lanes.early.insert(k, r);
                }
                Err(_) => break,
            }
        }
        match failure {
            Some(e) => Err(e),
            None => Ok(lanes),
        }
    }

    /// The outcome of trial `k`, waiting for it.
    pub(super) fn next(&mut self, k: usize) -> Result<Box<Finished>, Box<Failed>> {
        loop {
            if let Some(r) = self.early.remove(&k) {
                return r;
            }
            match self.reports.recv() {
                Ok(Report::Trial(j, r)) => {
                    self.early.insert(j, r);
                }
                Ok(Report::Ready(_)) => {}
                // Both lanes ended without reporting k: only after an abort.
                Err(_) => return Err(MasterError::Cancelled { trial: k }.into()),
            }
        }
    }
}
