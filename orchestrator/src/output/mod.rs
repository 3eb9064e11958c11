//! Result files the orchestrator leaves for users: per-trial recordings (CSV or Parquet),
//! summary tables and SVG plots.
//!
//! Every file goes through [`write_atomic`], so an interrupted run leaves either the previous
//! file or the complete new one, never a torn file that `--resume` or a reader would misparse.

mod atomic;
pub mod convergence_plot;
mod csv;
mod parquet;
pub mod plots;
mod recording;
pub mod sweep_plots;

use std::path::PathBuf;

pub use self::atomic::{Prepared, prepare_atomic, write_atomic};
pub use self::csv::{
    CsvExporter, CsvWithText, Exporter, push_csv_record, read_recording_csv, write_recorded_rows,
    write_recording, write_table_csv,
};
pub use self::parquet::ParquetExporter;
pub use self::recording::{RecordedRows, Recording};

/// Writes a command's text result (`info`, `analyze`, `simulate` without `--output`) to
/// standard output, flushed, so that a full disk behind a redirect is an error and not a
/// silently empty file. A reader that stopped early (`| head`) is no error of the command.
pub fn to_stdout(
    write: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
) -> std::io::Result<()> {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    match write(&mut out).and_then(|()| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}

/// `fs::create_dir_all` for an output folder, with a file in its way named: the system's
/// own "File exists" or "Not a directory" does not say which path is the file.
pub fn create_folder(dir: &std::path::Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| match dir.ancestors().find(|a| a.is_file()) {
        Some(file) => std::io::Error::new(
            e.kind(),
            format!("{} is a file, not a folder", file.display()),
        ),
        None => e,
    })
}

/// A simulation time for messages: to the nanosecond, trailing zeros dropped, so a time the
/// master reached by adding steps reads as the user wrote it (0.943, not 0.9430000000000001).
pub fn seconds(t: f64) -> String {
    let text = format!("{t:.9}");
    if !text.contains('.') {
        return text;
    }
    match text.trim_end_matches('0').trim_end_matches('.') {
        "-0" => "0".into(),
        short => short.into(),
    }
}

/// Failure to write or read a result file; every variant names the file so a user running a
/// long study knows which output is affected.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The operating system refused an operation on `path` (create, write, fsync, rename, read).
    #[error("I/O error on {}", path.display())]
    Io {
        /// The file the caller asked for (not the temporary file next to it).
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The CSV content of `path` is malformed, or the data to write is inconsistent.
    #[error("{}:{line}: {message}", path.display())]
    Csv {
        /// The CSV file.
        path: PathBuf,
        /// 1-based line of the offending record (the header is line 1).
        line: u64,
        /// What is wrong with that line.
        message: String,
    },
    /// A chart could not be laid out or rendered.
    #[error("cannot plot {}: {message}", path.display())]
    Plot {
        /// The SVG file.
        path: PathBuf,
        /// Why plotting failed.
        message: String,
    },
}

impl OutputError {
    /// The file this error is about.
    pub fn path(&self) -> &std::path::Path {
        match self {
            Self::Io { path, .. } | Self::Csv { path, .. } | Self::Plot { path, .. } => path,
        }
    }
}

#[cfg(test)]
mod seconds_tests {
    use super::seconds;

    #[test]
    fn times_read_as_written() {
        assert_eq!(seconds(0.943_000_000_000_000_1), "0.943");
        assert_eq!(seconds(0.1 + 0.2), "0.3");
        assert_eq!(seconds(15.0), "15");
        assert_eq!(seconds(0.0), "0");
        assert_eq!(seconds(-1e-12), "0");
        assert_eq!(seconds(-2.5), "-2.5");
        assert_eq!(seconds(1.5e-6), "0.0000015");
        assert_eq!(seconds(1e7 + 0.001), "10000000.001");
        assert_eq!(seconds(f64::NAN), "NaN");
        assert_eq!(seconds(f64::INFINITY), "inf");
    }
}
