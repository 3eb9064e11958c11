//! The co-simulation master: Gauss–Seidel stepping at t_n = t_0 + n·h, repeated trials
//! from the same initial state, and double-buffered iteration memory with a per-channel
//! update stage between trials (docs/model.md §6, §9).
//!
//! All buffers are sized once per campaign; the per-step loop only copies between
//! preallocated slices and calls the FMUs.

use std::ops::Range;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use ckcm::learning::MemoryUpdate;
use fmi2_import::{Fmu, ImportError, Instance};
use indicatif::ProgressBar;

use crate::output::{RecordedRows, seconds};
use crate::scenario::{Port, Scenario, describe_update};
use crate::variables::set_value;

/// A failure while running, naming the trial, the time and the call.
#[derive(Debug, thiserror::Error)]
pub enum MasterError {
    #[error("cannot instantiate FMU {fmu:?}: {source}")]
    Instantiate {
        fmu: String,
        source: Box<ImportError>,
    },
    #[error("trial {trial}, t = {} s: {what} of FMU {fmu:?} failed: {source}", seconds(*time))]
    Call {
        trial: usize,
        time: f64,
        fmu: String,
        what: &'static str,
        source: Box<ImportError>,
    },
    #[error(
        "trial {trial}, t = {} s: fmi2DoStep of FMU {fmu:?} was discarded{}{}: {source}",
        seconds(*time),
        last_successful_time.map(|t| format!(" (last successful time {} s)", seconds(t))).unwrap_or_default(),
        if *terminated { "; the FMU asks to terminate the simulation" } else { "" }
    )]
    Discard {
        trial: usize,
        time: f64,
        fmu: String,
        last_successful_time: Option<f64>,
        terminated: bool,
        source: Box<ImportError>,
    },
    #[error(
        "trial {trial}, t = {} s: FMU {fmu:?} returned {variable} = {value} from \
         fmi2GetReal with status fmi2OK; a value that is not finite stops the trial",
        seconds(*time)
    )]
    NotFinite {
        trial: usize,
        time: f64,
        fmu: String,
        variable: String,
        value: f64,
    },
    #[error("memory channel {channel:?}: {source}")]
    Update {
        channel: String,
        source: ckcm::learning::UpdateError,
    },
    #[error(
        "trial {trial}: the update of memory channel {channel:?} ([memory.update]: {settings}) \
         made the next trial's memory not finite: {variable} at t = {} s is {value}; no trial \
         can learn from it, so the campaign stops with the trials before this one",
        seconds(*time)
    )]
    UpdateNotFinite {
        trial: usize,
        channel: String,
        settings: String,
        variable: String,
        time: f64,
        value: f64,
    },
    #[error("trial {trial} stopped: the trial before it, whose memory it reads, did not finish")]
    Cancelled { trial: usize },
    #[error("trial {trial}: {what} of FMU {fmu:?} failed before the first step: {source}")]
    Setup {
        trial: usize,
        fmu: String,
        what: &'static str,
        source: Box<ImportError>,
    },
}

/// Log categories, in the naming Reference-FMUs and our FMUs use, that report failed or
/// questionable calls and nothing else.
pub const STATUS_CATEGORIES: [&str; 4] = [
    "logStatusWarning",
    "logStatusDiscard",
    "logStatusError",
    "logStatusFatal",
];

/// Values of one trial kept at full rate for the summary metrics.
#[derive(Debug, Clone, PartialEq)]
pub struct TrialSignals {
    /// t_n of each sample.
    pub time: Vec<f64>,
    /// Leg errors, `[sample][leg]`.
    pub error: Vec<[f64; 6]>,
    /// Platform position (x, y, z) at each sample, when a pose port is configured.
    pub position: Vec<[f64; 3]>,
}

impl TrialSignals {
    /// Drops every sample and keeps the capacity, so that the next trial allocates nothing.
    pub fn clear(&mut self) {
        self.time.clear();
        self.error.clear();
        self.position.clear();
    }
}

/// Steps per chunk of iteration memory that a pipelined trial hands to the next one.
pub const CHUNK_STEPS: usize = 256;

/// Elements of a metrics pose port that are tapped: x, y, z.
const POSITION: usize = 3;

/// Where the iteration memory of a trial comes from and goes to, chunk by chunk of
/// [`CHUNK_STEPS`] steps. Trial k+1 reads at step n only what trial k wrote at step n, so
/// with the plain update (u_{k+1} = m_k) it can run on another core a chunk behind trial k.
pub trait MemoryLink {
    /// Whether the master calls the link at all; [`Unlinked`] compiles it away.
    const ACTIVE: bool;
    /// Fills `read`, channel `c`'s memory for the steps of chunk `chunk`, before they run.
    fn receive(&mut self, c: usize, chunk: usize, read: &mut [f64]) -> Result<(), Stopped>;
    /// Hands on `written`, channel `c`'s m_k for the steps of chunk `chunk`.
    fn send(&mut self, c: usize, chunk: usize, written: &[f64]);
}

/// The trial that writes the memory stopped, or the campaign did.
#[derive(Debug)]
pub struct Stopped;

/// The memory stays in the master: each trial reads what the trial before wrote in full.
#[derive(Debug)]
pub struct Unlinked;

impl MemoryLink for Unlinked {
    const ACTIVE: bool = false;
    fn receive(&mut self, _: usize, _: usize, _: &mut [f64]) -> Result<(), Stopped> {
        Ok(())
    }
    fn send(&mut self, _: usize, _: usize, _: &[f64]) {}
}

/// Per-FMU wiring, resolved to value references and bus slots.
#[derive(Debug)]
struct Wiring {
    /// Outputs read after initialization and after every step of a recorded trial into
    /// `bus[bus_range]`: first those the coupling and the metrics need (see `out_needed`),
    /// then those only the recording reads.
    out_vrs: Vec<u32>,
    /// How many of `out_vrs` an unrecorded trial reads after every step. A recorded-only
    /// output can be costly to compute (the plant's Euler angles are computed only when read).
    out_needed: usize,
    /// Their names, for the error when one is not finite.
    out_names: Vec<String>,
    bus_range: Range<usize>,
    /// Real inputs set before every step.
    in_vrs: Vec<u32>,
    /// Where each input's value comes from, as runs over `in_buf`.
    in_runs: Vec<InRun>,
    in_buf: Vec<f64>,
    /// Bus slots copied into the row's columns (recorded, then the metrics') before the
    /// step (values at t_n).
    record_before: Vec<Run>,
    /// Bus slots copied into the row's columns after the step (values held over the step).
    record_after: Vec<Run>,
    /// The metrics' columns of `record_before` and `record_after` alone, for an unrecorded
    /// trial.
    metric_before: Vec<Run>,
    metric_after: Vec<Run>,
}

impl Wiring {
    /// A NaN or infinite output returned with fmi2OK would flow silently into the
    /// recordings, the memory and the summary; it ends the trial as a failed call does.
    /// Inlined, with the error built out of line, so a step pays only the scan.
    #[inline(always)]
    fn check_finite(
        &self,
        bus: &[f64],
        read: usize,
        trial: usize,
        time: f64,
        fmu: &str,
    ) -> Result<(), MasterError> {
        if all_finite(&bus[self.read_range(read)]) {
            Ok(())
        } else {
            Err(self.not_finite(bus, read, trial, time, fmu))
        }
    }

    /// The bus slots of the first `read` outputs.
    fn read_range(&self, read: usize) -> Range<usize> {
        self.bus_range.start..self.bus_range.start + read
    }

    #[cold]
    #[inline(never)]
    fn not_finite(
        &self,
        bus: &[f64],
        read: usize,
        trial: usize,
        time: f64,
        fmu: &str,
    ) -> MasterError {
        let outputs = &bus[self.read_range(read)];
        let i = outputs.iter().position(|x| !x.is_finite()).unwrap_or(0);
        MasterError::NotFinite {
            trial,
            time,
            fmu: fmu.to_owned(),
            variable: self.out_names[i].clone(),
            value: outputs[i],
        }
    }
}

/// Whether every value is finite, without a branch per value: an exponent field of all ones
/// (NaN or infinity) plus one reaches the sign bit, and any other does not. The compiler
/// vectorises this; a search with a branch per value, out of line, cost 3.4 M instructions
/// more per 15 s trial (BENCHMARKS.md, round 14). `#[inline]`, as `Run::copy`: the stepping
/// loop is generic, so it is compiled in the caller's crate (BENCHMARKS.md, round 34). The
/// FMU side has the same scan as `fmu_core::values::all_finite`; the master links no FMU
/// crate, so it is written here again.
#[inline]
fn all_finite(values: &[f64]) -> bool {
    const EXPONENT: u64 = 0x7ff0_0000_0000_0000;
    const ONE: u64 = 1 << 52;
    let carry = values
        .iter()
        .fold(0, |acc, x| acc | ((x.to_bits() & EXPONENT) + ONE));
    carry >> 63 == 0
}

/// `len` consecutive bus slots from `slot` copied to a row (the recording columns, or a
/// memory channel's elements) from `column`: an array variable's elements are one run,
/// copied as one slice rather than element by element (BENCHMARKS.md, round 7).
#[derive(Debug, Clone, Copy)]
struct Run {
    slot: usize,
    column: usize,
    len: usize,
}

impl Run {
    /// Appends slot `slot` → column `column`, extending the last run when both continue it.
    fn push(runs: &mut Vec<Run>, slot: usize, column: usize) {
        match runs.last_mut() {
            Some(r) if r.slot + r.len == slot && r.column + r.len == column => r.len += 1,
            _ => runs.push(Run {
                slot,
                column,
                len: 1,
            }),
        }
    }

    #[inline]
    fn copy(runs: &[Run], bus: &[f64], row: &mut [f64]) {
        for r in runs {
            row[r.column..r.column + r.len].copy_from_slice(&bus[r.slot..r.slot + r.len]);
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Source {
    Bus(usize),
    /// Memory channel, element.
    Memory(usize, usize),
}

impl Source {
    /// The source `k` places further on.
    fn offset(self, k: usize) -> Self {
        match self {
            Source::Bus(s) => Source::Bus(s + k),
            Source::Memory(c, i) => Source::Memory(c, i + k),
        }
    }
}

/// Inputs `at..at + len` of an FMU's `in_buf`, filled from `len` consecutive bus slots or
/// elements of one memory channel: a connected array variable is one slice copy per step
/// rather than one match per scalar.
#[derive(Debug, Clone, Copy)]
struct InRun {
    at: usize,
    src: Source,
    len: usize,
}

impl InRun {
    /// Appends input `at` ← `src`, extending the last run when both continue it.
    fn push(runs: &mut Vec<InRun>, at: usize, src: Source) {
        match runs.last_mut() {
            Some(r) if r.at + r.len == at && r.src.offset(r.len) == src => r.len += 1,
            _ => runs.push(InRun { at, src, len: 1 }),
        }
    }
}

#[derive(Debug)]
struct Channel {
    width: usize,
    /// Bus slots of the producing output, read after the producer's step, as runs onto
    /// the channel's elements.
    from_runs: Vec<Run>,
    /// FMU whose step produces the values.
    producer: usize,
    read: Vec<f64>,
    write: Vec<f64>,
    /// The robust update between trials; `None`: the paper's plain buffer swap.
    update: Option<MemoryUpdate>,
}

impl Channel {
    /// End of a trial: the update stage turns the written m_k into u_{k+1}
    /// (docs/model.md §9), which becomes the read buffer of the next trial. `Err(i)`: the
    /// update made element `i` (sample i / width) not finite, and nothing is swapped. The
    /// plain swap needs no check: its values passed the outputs' own.
    fn end_trial(&mut self) -> Result<(), usize> {
        if let Some(u) = &mut self.update {
            u.apply(&self.read, &mut self.write);
            if let Some(i) = self.write.iter().position(|x| !x.is_finite()) {
                return Err(i);
            }
        }
        std::mem::swap(&mut self.read, &mut self.write);
        Ok(())
    }
}

/// Loaded FMUs, instances and buffers for one scenario.
#[derive(Debug)]
pub struct Master<'s> {
    scenario: &'s Scenario,
    // Instances borrow nothing from the Fmu values but need their libraries and unpacked
    // files kept alive: held, never read; declared before them so they are dropped first.
    instances: Vec<Instance>,
    _fmus: Vec<Fmu>,
    wiring: Vec<Wiring>,
    bus: Vec<f64>,
    channels: Vec<Channel>,
    /// One sample: recorded columns, then the six leg errors (or six references and six
    /// true lengths), then x, y, z.
    row: Vec<f64>,
    column_names: Vec<String>,
    has_error: bool,
    /// Whether the leg errors are reference − length rather than an error output.
    error_difference: bool,
    has_pose: bool,
    initialized_once: bool,
    /// Whether the FMUs' log messages are forwarded to stderr as they come (`--fmu-logging`).
    logging: bool,
    /// Where the FMUs' messages are shown while trials run ([`Master::set_console`]).
    console: FmuConsole,
}

/// Where a master shows what its FMUs say while trials run: through the campaign's progress
/// bar, which `suspend`s itself so that its redraw does not erase the message, and with one
/// flag per FMU saying whether a warning of its fmi2DoStep has been shown. Without
/// `--fmu-logging` only the first is, so that an FMU that warns every step does not flood
/// the console; the masters of a campaign's lanes share one `FmuConsole` (clones share the
/// flags), so that the campaign says it once.
#[derive(Clone, Debug)]
pub struct FmuConsole {
    bar: ProgressBar,
    warned: Arc<[AtomicBool]>,
    /// What a message names first: the campaign's folder and ": ", or nothing.
    campaign: String,
}

impl FmuConsole {
    /// A console for `fmus` FMUs printing through `bar` (`ProgressBar::hidden()` for none).
    pub fn new(bar: ProgressBar, fmus: usize) -> Self {
        Self {
            bar,
            warned: (0..fmus).map(|_| AtomicBool::new(false)).collect(),
            campaign: String::new(),
        }
    }

    /// Names the campaign folder `dir` in each warning: a sweep or the paper study runs many
    /// campaigns, and "trial 0" alone would not say which.
    pub fn for_campaign(mut self, dir: &std::path::Path) -> Self {
        self.campaign = format!("{}: ", dir.display());
        self
    }

    /// The progress bar it prints through.
    pub fn bar(&self) -> &ProgressBar {
        &self.bar
    }
}

impl<'s> Master<'s> {
    /// Instantiates every FMU of `scenario` (already opened as `fmus`, in scenario order)
    /// and resolves the wiring.
    pub fn new(scenario: &'s Scenario, fmus: Vec<Fmu>, logging: bool) -> Result<Self, MasterError> {
        let mut instances = Vec::with_capacity(fmus.len());
        for (spec, fmu) in scenario.fmus.iter().zip(&fmus) {
            let instantiate_err = |source| MasterError::Instantiate {
                fmu: spec.name.clone(),
                source: Box::new(source),
            };
            let mut inst = fmu
                .instantiate(&spec.name, logging)
                .map_err(instantiate_err)?;
            if logging {
                // Every category, as `simulate --fmu-logging` asks.
                inst.set_debug_logging(true, &[]).map_err(instantiate_err)?;
            } else {
                // Without debug logging, still hear why a call fails: enable the status
                // categories the FMU declares (they log only when something goes wrong).
                let status: Vec<&str> = fmu
                    .model_description()
                    .log_categories
                    .iter()
                    .map(|c| c.name.as_str())
                    .filter(|n| STATUS_CATEGORIES.contains(n))
                    .collect();
                if !status.is_empty() {
                    inst.set_debug_logging(true, &status)
                        .map_err(instantiate_err)?;
                }
            }
            instances.push(inst);
        }
        // Every output anyone needs gets a bus slot, grouped per FMU: first those the
        // coupling and the metrics read, then those only a recording reads.
        let n = scenario.fmus.len();
        let mut needed: Vec<(Vec<u32>, Vec<String>)> = vec![(Vec::new(), Vec::new()); n];
        // The first `take` elements of `p`.
        let need = |needed: &mut [(Vec<u32>, Vec<String>)], p: &Port, take: usize| {
            let (vrs, names) = &mut needed[p.fmu];
            for (&vr, name) in p.value_references.iter().zip(&p.names).take(take) {
                if !vrs.contains(&vr) {
                    vrs.push(vr);
                    names.push(name.clone());
                }
            }
        };
        for l in scenario
            .connections
            .iter()
            .chain(scenario.memory.iter().map(|m| &m.link))
        {
            need(&mut needed, &l.from, usize::MAX);
        }
        if let Some(m) = &scenario.metrics {
            for p in m.error.ports() {
                need(&mut needed, p, usize::MAX);
            }
            if let Some(p) = &m.pose {
                need(&mut needed, p, POSITION);
            }
        }
        let out_needed: Vec<usize> = needed.iter().map(|(vrs, _)| vrs.len()).collect();
        for p in &scenario.record.ports {
            need(&mut needed, p, usize::MAX);
        }
        let mut wiring = Vec::with_capacity(n);
        let mut next = 0;
        for ((vrs, names), out_needed) in needed.into_iter().zip(out_needed) {
            let range = next..next + vrs.len();
            next = range.end;
            wiring.push(Wiring {
                out_vrs: vrs,
                out_needed,
                out_names: names,
                bus_range: range,
                in_vrs: Vec::new(),
                in_runs: Vec::new(),
                in_buf: Vec::new(),
                record_before: Vec::new(),
                record_after: Vec::new(),
                metric_before: Vec::new(),
                metric_after: Vec::new(),
            });
        }
        let slot = |wiring: &[Wiring], fmu: usize, vr: u32| {
            let w = &wiring[fmu];
            w.bus_range.start
                + w.out_vrs
                    .iter()
                    .position(|&x| x == vr)
                    .expect("every needed output has a slot")
        };
        for l in &scenario.connections {
            for (i, &vr) in l.to.value_references.iter().enumerate() {
                let s = slot(&wiring, l.from.fmu, l.from.value_references[i]);
                let w = &mut wiring[l.to.fmu];
                InRun::push(&mut w.in_runs, w.in_vrs.len(), Source::Bus(s));
                w.in_vrs.push(vr);
            }
        }
        let steps = scenario.steps;
        let mut channels = Vec::new();
        for (c, m) in scenario.memory.iter().enumerate() {
            let l = &m.link;
            let width = l.from.value_references.len();
            let mut from_runs = Vec::new();
            for (i, &vr) in l.from.value_references.iter().enumerate() {
                Run::push(&mut from_runs, slot(&wiring, l.from.fmu, vr), i);
            }
            for (i, &vr) in l.to.value_references.iter().enumerate() {
                let w = &mut wiring[l.to.fmu];
                InRun::push(&mut w.in_runs, w.in_vrs.len(), Source::Memory(c, i));
                w.in_vrs.push(vr);
            }
            let update = match m.update {
                None => None,
                Some(settings) => Some(
                    MemoryUpdate::new(settings, steps, width, scenario.step_size).map_err(
                        |source| MasterError::Update {
                            channel: l.to.reference.clone(),
                            source,
                        },
                    )?,
                ),
            };
            channels.push(Channel {
                width,
                from_runs,
                producer: l.from.fmu,
                read: vec![0.0; steps * width],
                write: vec![0.0; steps * width],
                update,
            });
        }
        let mut column_names = Vec::new();
        let mut taps: Vec<&Port> = scenario.record.ports.iter().collect();
        let metrics = scenario.metrics.as_ref();
        taps.extend(metrics.into_iter().flat_map(|m| m.error.ports()));
        taps.extend(metrics.and_then(|m| m.pose.as_ref()));
        let mut columns = 0;
        for (t, p) in taps.iter().enumerate() {
            let is_record = t < scenario.record.ports.len();
            // The pose port may be longer than x, y, z; only those three are tapped.
            let take = if is_record || !metrics.is_some_and(|m| m.pose.as_ref() == Some(*p)) {
                p.value_references.len()
            } else {
                POSITION
            };
            for (i, &vr) in p.value_references.iter().take(take).enumerate() {
                if is_record {
                    column_names.push(p.names[i].clone());
                }
                let s = slot(&wiring, p.fmu, vr);
                let w = &mut wiring[p.fmu];
                let (all, metric) = if p.sampled {
                    (&mut w.record_after, &mut w.metric_after)
                } else {
                    (&mut w.record_before, &mut w.metric_before)
                };
                Run::push(all, s, columns);
                if !is_record {
                    Run::push(metric, s, columns);
                }
                columns += 1;
            }
        }
        for w in &mut wiring {
            w.in_buf = vec![0.0; w.in_vrs.len()];
        }
        let master = Self {
            scenario,
            instances,
            _fmus: fmus,
            bus: vec![0.0; next],
            channels,
            row: vec![0.0; columns],
            column_names,
            wiring,
            has_error: metrics.is_some(),
            error_difference: metrics
                .is_some_and(|m| matches!(m.error, crate::scenario::LegError::Difference { .. })),
            has_pose: metrics.is_some_and(|m| m.pose.is_some()),
            initialized_once: false,
            logging,
            console: FmuConsole::new(ProgressBar::hidden(), scenario.fmus.len()),
        };
        master.forward_log();
        Ok(master)
    }

    /// Shows the FMUs' messages through `console` from now on (see [`FmuConsole`]); it must
    /// have been made for this scenario's FMUs.
    pub fn set_console(&mut self, console: FmuConsole) {
        debug_assert_eq!(
            console.warned.len(),
            self.instances.len(),
            "one flag per FMU"
        );
        self.console = console;
    }

    /// Names of the outputs that feed the memory channels, channel by channel.
    pub fn memory_names(&self) -> Vec<String> {
        self.scenario
            .memory
            .iter()
            .flat_map(|m| m.link.from.names.iter().cloned())
            .collect()
    }

    /// The read buffers (memory used by the next trial), channel by channel.
    pub fn memory(&self) -> Vec<&[f64]> {
        self.channels.iter().map(|c| c.read.as_slice()).collect()
    }

    /// Replaces the read buffers (resume): one slice per channel, `steps × width` long.
    pub fn set_memory(&mut self, data: &[Vec<f64>]) {
        for (c, d) in self.channels.iter_mut().zip(data) {
            c.read.copy_from_slice(d);
        }
    }

    /// A fresh recording with room for one trial, in rows as the loop writes them
    /// ([`RecordedRows::to_recording`] gives the columns).
    pub fn new_recording(&self) -> RecordedRows {
        let rows = self.scenario.steps.div_ceil(self.scenario.record.interval);
        RecordedRows::with_capacity(self.column_names.clone(), rows)
    }

    /// Full-rate signal storage for one trial.
    pub fn new_signals(&self) -> TrialSignals {
        let n = self.scenario.steps;
        TrialSignals {
            time: Vec::with_capacity(n),
            error: Vec::with_capacity(n),
            position: Vec::with_capacity(if self.has_pose { n } else { 0 }),
        }
    }

    fn start_trial(&mut self, trial: usize) -> Result<(), MasterError> {
        let sc = self.scenario;
        for (k, inst) in self.instances.iter_mut().enumerate() {
            let spec = &sc.fmus[k];
            let setup = |what: &'static str| {
                move |source| MasterError::Setup {
                    trial,
                    fmu: spec.name.clone(),
                    what,
                    source: Box::new(source),
                }
            };
            if self.initialized_once {
                inst.reset().map_err(setup("fmi2Reset"))?;
            }
            // Per-trial values (e.g. a noise seed) make each trial draw fresh noise while
            // trial k always gets the same values, also on resume.
            for s in &spec.settings {
                set_value(inst, s.value_reference, &s.value_in_trial(trial))
                    .map_err(setup("setting parameters"))?;
            }
            inst.setup_experiment(None, sc.start_time, Some(sc.stop_time))
                .map_err(setup("fmi2SetupExperiment"))?;
            inst.enter_initialization_mode()
                .map_err(setup("fmi2EnterInitializationMode"))?;
        }
        for (k, inst) in self.instances.iter_mut().enumerate() {
            let spec = &sc.fmus[k];
            inst.exit_initialization_mode()
                .map_err(|source| MasterError::Setup {
                    trial,
                    fmu: spec.name.clone(),
                    what: "fmi2ExitInitializationMode",
                    source: Box::new(source),
                })?;
            let w = &self.wiring[k];
            inst.get_real(&w.out_vrs, &mut self.bus[w.bus_range.clone()])
                .map_err(|source| MasterError::Setup {
                    trial,
                    fmu: spec.name.clone(),
                    what: "fmi2GetReal",
                    source: Box::new(source),
                })?;
            w.check_finite(&self.bus, w.out_vrs.len(), trial, sc.start_time, &spec.name)?;
        }
        self.initialized_once = true;
        self.forward_log();
        Ok(())
    }

    /// With `--fmu-logging`, prints what each FMU logged since the last call, prefixed by its
    /// instance name, as `simulate` does. Without it nothing is printed here: a failed call
    /// carries its FMU's messages in its error.
    #[inline]
    fn forward_log(&self) {
        if self.logging {
            self.print_log();
        }
    }

    /// Out of line: only `--fmu-logging` runs it, and `forward_log` is in every step.
    #[inline(never)]
    fn print_log(&self) {
        self.console.bar.suspend(|| {
            for inst in &self.instances {
                for record in inst.take_log() {
                    crate::console!("{}: {record}", inst.name());
                }
            }
        });
    }

    /// Runs trial `trial` with the current read buffers, filling the write buffers,
    /// `recording` (if given; cleared first) and `signals` (cleared first). On success each
    /// channel's update stage makes the memory of the next trial from them.
    pub fn run_trial(
        &mut self,
        trial: usize,
        recording: Option<&mut RecordedRows>,
        signals: &mut TrialSignals,
        on_step: impl FnMut(usize),
    ) -> Result<(), MasterError> {
        self.run_trial_linked(trial, recording, signals, on_step, &mut Unlinked)
    }

    /// Whether every memory channel's update is the paper's plain u_{k+1} = m_k, so that a
    /// trial can start before the one before it has finished ([`MemoryLink`]).
    pub fn memory_is_plain(scenario: &Scenario) -> bool {
        scenario.memory.iter().all(|m| m.update.is_none())
    }

    /// [`Master::run_trial`] with the memory read from and handed on through `link`, chunk
    /// by chunk; the read buffers are filled by the link as the trial reaches them.
    pub fn run_trial_linked<L: MemoryLink>(
        &mut self,
        trial: usize,
        mut recording: Option<&mut RecordedRows>,
        signals: &mut TrialSignals,
        on_step: impl FnMut(usize),
        link: &mut L,
    ) -> Result<(), MasterError> {
        // Cleared before anything can fail: a trial that fails at its start must not hand
        // back rows of an earlier trial whose buffer this one reuses.
        if let Some(r) = recording.as_deref_mut() {
            r.clear();
        }
        self.start_trial(trial)?;
        // A failed trial's recording keeps every step up to the failure.
        self.step_trial(trial, recording, signals, on_step, link)?;
        for (ch, m) in self.channels.iter_mut().zip(&self.scenario.memory) {
            ch.end_trial().map_err(|i| {
                let u = ch.update.as_ref().map(MemoryUpdate::settings);
                MasterError::UpdateNotFinite {
                    trial,
                    channel: m.link.to.reference.clone(),
                    settings: u.map(describe_update).unwrap_or_default(),
                    variable: m.link.to.names[i % ch.width].clone(),
                    time: self.scenario.time(i / ch.width),
                    value: ch.write[i],
                }
            })?;
        }
        Ok(())
    }

    /// The stepping loop of [`Master::run_trial_linked`].
    fn step_trial<L: MemoryLink>(
        &mut self,
        trial: usize,
        mut recording: Option<&mut RecordedRows>,
        signals: &mut TrialSignals,
        mut on_step: impl FnMut(usize),
        link: &mut L,
    ) -> Result<(), MasterError> {
        let sc = self.scenario;
        signals.clear();
        let h = sc.step_size;
        let interval = sc.record.interval;
        let recorded = recording.is_some();
        for n in 0..sc.steps {
            if L::ACTIVE && n % CHUNK_STEPS == 0 {
                let end = (n + CHUNK_STEPS).min(sc.steps);
                for (c, ch) in self.channels.iter_mut().enumerate() {
                    let read = &mut ch.read[n * ch.width..end * ch.width];
                    link.receive(c, n / CHUNK_STEPS, read)
                        .map_err(|Stopped| MasterError::Cancelled { trial })?;
                }
            }
            let t = sc.time(n);
            for k in 0..self.instances.len() {
                let w = &mut self.wiring[k];
                let before = if recorded {
                    &w.record_before
                } else {
                    &w.metric_before
                };
                Run::copy(before, &self.bus, &mut self.row);
                if !w.in_vrs.is_empty() {
                    let (bus, channels) = (&self.bus, &self.channels);
                    let source = |src: Source, len: usize| match src {
                        Source::Bus(s) => &bus[s..s + len],
                        Source::Memory(c, i) => {
                            let from = n * channels[c].width + i;
                            &channels[c].read[from..from + len]
                        }
                    };
                    // Inputs that are one run of bus slots or of a memory channel are set
                    // from where they are: no copy between an FMU's output and the next
                    // FMU's input.
                    let values = match *w.in_runs.as_slice() {
                        [r] => source(r.src, r.len),
                        _ => {
                            for r in &w.in_runs {
                                w.in_buf[r.at..r.at + r.len].copy_from_slice(source(r.src, r.len));
                            }
                            &w.in_buf
                        }
                    };
                    let inst = &mut self.instances[k];
                    if let Err(source) = inst.set_real(&w.in_vrs, values) {
                        return Err(call_failed(sc, k, trial, t, "fmi2SetReal", source));
                    }
                }
                let inst = &mut self.instances[k];
                match inst.do_step(t, h, true) {
                    Ok(fmi2_import::Status::Ok) => {}
                    Ok(_) if self.logging => {}
                    Ok(_) => step_warned(inst, trial, t, &self.console, k),
                    Err(source) => return Err(step_failed(sc, k, inst, trial, t, source)),
                }
                let read = if recorded {
                    w.out_vrs.len()
                } else {
                    w.out_needed
                };
                if let Err(source) =
                    inst.get_real(&w.out_vrs[..read], &mut self.bus[w.read_range(read)])
                {
                    let time = sc.time(n + 1);
                    return Err(call_failed(sc, k, trial, time, "fmi2GetReal", source));
                }
                w.check_finite(&self.bus, read, trial, sc.time(n + 1), &sc.fmus[k].name)?;
                let after = if recorded {
                    &w.record_after
                } else {
                    &w.metric_after
                };
                Run::copy(after, &self.bus, &mut self.row);
                for ch in self.channels.iter_mut().filter(|c| c.producer == k) {
                    let dst = &mut ch.write[n * ch.width..(n + 1) * ch.width];
                    Run::copy(&ch.from_runs, &self.bus, dst);
                }
            }
            let ncols = self.column_names.len();
            let mut pose_col = ncols;
            if self.has_error {
                let taps = &self.row[ncols..];
                signals.error.push(std::array::from_fn(|leg| {
                    if self.error_difference {
                        taps[leg] - taps[6 + leg]
                    } else {
                        taps[leg]
                    }
                }));
                pose_col += if self.error_difference { 12 } else { 6 };
            }
            if self.has_pose {
                let p = &self.row[pose_col..pose_col + 3];
                signals.position.push([p[0], p[1], p[2]]);
            }
            signals.time.push(t);
            // The recording first: an unrecorded trial pays no division.
            if let Some(r) = recording.as_deref_mut() {
                if n % interval == 0 {
                    r.push(t, &self.row[..ncols]);
                }
            }
            if L::ACTIVE && ((n + 1) % CHUNK_STEPS == 0 || n + 1 == sc.steps) {
                let start = n / CHUNK_STEPS * CHUNK_STEPS;
                for (c, ch) in self.channels.iter().enumerate() {
                    link.send(
                        c,
                        n / CHUNK_STEPS,
                        &ch.write[start * ch.width..(n + 1) * ch.width],
                    );
                }
            }
            self.forward_log();
            on_step(n);
        }
        Ok(())
    }
}

// The stepping loop's errors, built out of line and cold so that the loop's own code stays
// in few cache lines (BENCHMARKS.md, round 33).

/// FMU `k`'s call `what` at `time` failed.
#[cold]
#[inline(never)]
fn call_failed(
    sc: &Scenario,
    k: usize,
    trial: usize,
    time: f64,
    what: &'static str,
    source: ImportError,
) -> MasterError {
    MasterError::Call {
        trial,
        time,
        fmu: sc.fmus[k].name.clone(),
        what,
        source: Box::new(source),
    }
}

/// FMU `inst`'s doStep from `time` returned fmi2Warning: the step stands, and the user hears
/// why (the FMU's first warning, with trial and time; `--fmu-logging` shows them all).
#[cold]
#[inline(never)]
fn step_warned(inst: &Instance, trial: usize, time: f64, console: &FmuConsole, k: usize) {
    let log = inst.take_log();
    if console.warned[k].swap(true, Ordering::Relaxed) {
        return;
    }
    let warnings: Vec<_> = log
        .iter()
        .filter(|r| r.status == fmi2_import::Status::Warning)
        .map(|r| r.message.as_str())
        .collect();
    let text = if warnings.is_empty() {
        "(it logged no message)".to_owned()
    } else {
        warnings.join("; ")
    };
    console.bar.suspend(|| {
        crate::console!(
            "warning: {}trial {trial}, t = {} s: FMU {:?} returned fmi2Warning from \
             fmi2DoStep: {text}\n  (its further warnings in this campaign are not shown; \
             --fmu-logging shows every message)",
            console.campaign,
            seconds(time),
            inst.name()
        );
    });
}

/// FMU `k`'s doStep from `time` failed; for fmi2Discard (the FMU stopped early) the error
/// says where, as far as the FMU tells.
#[cold]
#[inline(never)]
fn step_failed(
    sc: &Scenario,
    k: usize,
    inst: &mut Instance,
    trial: usize,
    time: f64,
    source: ImportError,
) -> MasterError {
    if !matches!(
        source,
        ImportError::Call {
            status: fmi2_import::Status::Discard,
            ..
        }
    ) {
        return call_failed(sc, k, trial, time, "fmi2DoStep", source);
    }
    MasterError::Discard {
        trial,
        time,
        fmu: sc.fmus[k].name.clone(),
        last_successful_time: inst.last_successful_time().ok(),
        terminated: inst.is_terminated().unwrap_or(false),
        source: Box::new(source),
    }
}

#[cfg(test)]
mod tests {
    use super::all_finite;

    #[test]
    fn all_finite_agrees_with_is_finite() {
        let special = [
            0.0,
            -0.0,
            f64::MIN_POSITIVE,
            5e-324,
            -5e-324,
            f64::MAX,
            f64::MIN,
            f64::NAN,
            -f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::from_bits(0x7ff0_0000_0000_0001),
            f64::from_bits(0xfff8_dead_beef_0000),
        ];
        // Every value alone and after a run of finite ones, and random bit patterns.
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut random = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            f64::from_bits(state)
        };
        let mut cases: Vec<Vec<f64>> = special.iter().map(|&x| vec![x]).collect();
        cases.extend(special.iter().map(|&x| [vec![1.5; 37], vec![x]].concat()));
        cases.extend((0..2000).map(|n| (0..n % 40).map(|_| random()).collect()));
        cases.push(Vec::new());
        for values in cases {
            assert_eq!(
                all_finite(&values),
                values.iter().all(|x| x.is_finite()),
                "{values:?}"
            );
        }
    }
}
