//! The per-instance log buffer behind `componentEnvironment`, fed by the C shim.

use std::collections::VecDeque;
use std::ffi::{CStr, c_char, c_int, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, PoisonError};

use fmi2_sys::{Fmi2ComponentEnvironment, Fmi2String, Status};

unsafe extern "C" {
    /// The variadic `fmi2CallbackLogger` of `csrc/logger.c`.
    pub(crate) fn fmi2_import_logger(
        env: Fmi2ComponentEnvironment,
        instance_name: Fmi2String,
        status: c_int,
        category: Fmi2String,
        message: Fmi2String,
        ...
    );
}

/// At most this many records are kept; older ones are dropped (and counted) so a
/// chatty FMU with logging on cannot grow the master's memory without bound.
pub const MAX_LOG_RECORDS: usize = 10_000;

/// One message an FMU logged.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogRecord {
    /// The status the FMU attached (an out-of-range status is recorded as `Error`, with
    /// the raw value noted in the message).
    pub status: Status,
    /// The log category, e.g. `logStatusError`.
    pub category: String,
    /// The formatted message.
    pub message: String,
}

impl std::fmt::Display for LogRecord {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "[{}] {}: {}", self.status, self.category, self.message)
    }
}

/// Records plus the sequence number of the first one, so a call can find what was
/// logged while it ran.
#[derive(Debug, Default)]
struct Records {
    entries: VecDeque<(u64, LogRecord)>,
    dropped: usize,
}

/// The component environment of one instance. `#[repr(C)]` with `sink` first: the C
/// shim reads that field to forward messages (see `csrc/logger.c`).
#[repr(C)]
#[derive(Debug)]
pub(crate) struct LogEnv {
    sink: unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char),
    /// Number of messages received so far; read before each call without locking.
    next_seq: AtomicU64,
    records: Mutex<Records>,
}

impl LogEnv {
    pub(crate) fn new() -> Self {
        Self {
            sink: log_sink,
            next_seq: AtomicU64::new(0),
            records: Mutex::new(Records::default()),
        }
    }

    /// The sequence number the next message will get.
    #[inline]
    pub(crate) fn mark(&self) -> u64 {
        self.next_seq.load(Ordering::Acquire)
    }

    fn push(&self, record: LogRecord) {
        let mut records = self.records.lock().unwrap_or_else(PoisonError::into_inner);
        let seq = self.next_seq.fetch_add(1, Ordering::AcqRel);
        if records.entries.len() >= MAX_LOG_RECORDS {
            records.entries.pop_front();
            records.dropped += 1;
        }
        records.entries.push_back((seq, record));
    }

    /// Copies of the messages logged since `mark`.
    pub(crate) fn since(&self, mark: u64) -> Vec<LogRecord> {
        let records = self.records.lock().unwrap_or_else(PoisonError::into_inner);
        records
            .entries
            .iter()
            .filter(|(seq, _)| *seq >= mark)
            .map(|(_, r)| r.clone())
            .collect()
    }

    /// Removes and returns every record, preceded by a note if some were dropped.
    pub(crate) fn take(&self) -> Vec<LogRecord> {
        let mut records = self.records.lock().unwrap_or_else(PoisonError::into_inner);
        let mut out = Vec::with_capacity(records.entries.len() + 1);
        if records.dropped > 0 {
            out.push(LogRecord {
                status: Status::Warning,
                category: "fmi2-import".into(),
                message: format!(
                    "{} earlier log messages were dropped (limit {MAX_LOG_RECORDS})",
                    records.dropped
                ),
            });
            records.dropped = 0;
        }
        out.extend(records.entries.drain(..).map(|(_, r)| r));
        out
    }
}

/// Text of a C string the FMU passed, or "" for NULL.
///
/// # Safety
/// `ptr` is NULL or a NUL-terminated string valid for the duration of the call.
unsafe fn text(ptr: *const c_char) -> String {
    if ptr.is_null() {
        String::new()
    } else {
        // SAFETY: non-null, and the caller guarantees NUL termination and validity.
        unsafe { CStr::from_ptr(ptr) }
            .to_string_lossy()
            .into_owned()
    }
}

/// Receives each formatted message from the C shim.
unsafe extern "C" fn log_sink(
    env: *mut c_void,
    _instance_name: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    // A panic must not unwind into C; a lost log line is the lesser evil.
    let _ = catch_unwind(AssertUnwindSafe(|| {
        if env.is_null() {
            return;
        }
        // SAFETY: `env` is the `componentEnvironment` this crate passed to
        // fmi2Instantiate: a `LogEnv` in a Box that outlives the instance (it is freed
        // only after fmi2FreeInstance). The shim only calls with that pointer.
        let env = unsafe { &*(env as *const LogEnv) };
        // SAFETY: the shim passes NUL-terminated strings (or NULL) valid during this call.
        let (category, mut message) = unsafe { (text(category), text(message)) };
        let status = Status::try_from(status).unwrap_or_else(|invalid| {
            message = format!("({invalid}) {message}");
            Status::Error
        });
        env.push(LogRecord {
            status,
            category,
            message,
        });
    }));
}
