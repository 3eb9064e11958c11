//! CSV export and import of recordings, and generic summary tables.
//!
//! The `csv` crate does the quoting and parsing; only number formatting is done here, because
//! recordings must read back bit-exactly (`--resume` continues from stored learning memory).

use std::fs::File;
use std::io::{self, BufReader, Write};
use std::path::Path;
use std::sync::mpsc::sync_channel;

use ::csv::{ErrorKind, ReaderBuilder, StringRecord, Writer};

use super::{OutputError, RecordedRows, Recording, write_atomic};

/// A file format for recordings. Behind a trait so new formats can be added without touching
/// the code that decides what to record and where.
pub trait Exporter {
    /// File name extension without the dot, e.g. `"csv"`.
    fn extension(&self) -> &'static str;
    /// Serialises `rec` into `w`. Fails with [`io::ErrorKind::InvalidData`] if the columns of
    /// `rec` are not all as long as its time vector.
    fn write(&self, rec: &Recording, w: &mut dyn Write) -> io::Result<()>;
    /// Serialises a master's rows into `w`, the same bytes as [`Exporter::write`] of
    /// [`RecordedRows::to_recording`]. A format that can read the rows as they are overrides
    /// it, so that a writer holds no second copy of the trial.
    fn write_rows(&self, rows: &RecordedRows, w: &mut dyn Write) -> io::Result<()> {
        self.write(&rows.to_recording(), w)
    }
}

/// Comma-separated values: header `time,<names...>`, one row per sample, every number in the
/// shortest form that parses back to the identical `f64`.
#[derive(Debug, Clone, Copy, Default)]
pub struct CsvExporter;

impl Exporter for CsvExporter {
    fn extension(&self) -> &'static str {
        "csv"
    }

    fn write(&self, rec: &Recording, w: &mut dyn Write) -> io::Result<()> {
        write_csv(rec, &[], w)
    }

    fn write_rows(&self, rows: &RecordedRows, w: &mut dyn Write) -> io::Result<()> {
        write_header(rows.names(), w)?;
        write_number_rows(rows, w)
    }
}

/// [`CsvExporter`]'s format with some columns holding text (FMI String variables): column
/// `i` of `text` replaces the numeric column `text[i].0` of the recording, whose numbers are
/// then ignored. Text is quoted by the `csv` crate where needed.
#[derive(Debug, Clone, Default)]
pub struct CsvWithText {
    /// (column index, one value per row).
    pub text: Vec<(usize, Vec<String>)>,
}

impl Exporter for CsvWithText {
    fn extension(&self) -> &'static str {
        "csv"
    }

    fn write(&self, rec: &Recording, w: &mut dyn Write) -> io::Result<()> {
        if let Some((c, t)) = self
            .text
            .iter()
            .find(|(c, t)| *c >= rec.columns.len() || t.len() != rec.time.len())
        {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "text column {c} has {} rows for {} columns of {} rows",
                    t.len(),
                    rec.columns.len(),
                    rec.time.len()
                ),
            ));
        }
        write_csv(rec, &self.text, w)
    }
}

fn write_csv(rec: &Recording, text: &[(usize, Vec<String>)], w: &mut dyn Write) -> io::Result<()> {
    if let Some(message) = rec.shape_error() {
        return Err(io::Error::new(io::ErrorKind::InvalidData, message));
    }
    if text.is_empty() {
        write_header(&rec.names, w)?;
        return write_number_rows(rec, w);
    }
    let mut out = Writer::from_writer(w);
    write_names(&mut out, &rec.names)?;
    // Per column: its text, if it is a text column.
    let texts: Vec<Option<&Vec<String>>> = (0..rec.columns.len())
        .map(|c| text.iter().find(|(i, _)| *i == c).map(|(_, t)| t))
        .collect();
    // One reused buffer for all numbers: a recording has ~10^5 rows of ~20 fields.
    let mut numbers = Numbers::default();
    for (row, &t) in rec.time.iter().enumerate() {
        out.write_field(numbers.format(t))?;
        for (column, text) in rec.columns.iter().zip(&texts) {
            match text {
                Some(text) => out.write_field(&text[row])?,
                None => out.write_field(numbers.format(column[row]))?,
            }
        }
        out.write_record(None::<&[u8]>)?;
    }
    out.flush()
}

/// The header line: `time`, then `names`, quoted by the `csv` crate where needed.
fn write_header(names: &[String], w: &mut dyn Write) -> io::Result<()> {
    let mut out = Writer::from_writer(w);
    write_names(&mut out, names)?;
    out.flush()
}

fn write_names<W: Write>(out: &mut Writer<W>, names: &[String]) -> io::Result<()> {
    out.write_field("time")?;
    for name in names {
        out.write_field(name)?;
    }
    out.write_record(None::<&[u8]>)?;
    Ok(())
}

/// Numbers read a row at a time, whichever way they are stored: a [`Recording`]'s columns,
/// or the rows a master recorded.
trait NumberRows: Sync {
    fn len(&self) -> usize;
    fn width(&self) -> usize;
    fn time_at(&self, row: usize) -> f64;
    /// Calls `f` with row `row`'s values in column order.
    fn each_in_row(&self, row: usize, f: impl FnMut(f64));
}

impl NumberRows for Recording {
    fn len(&self) -> usize {
        self.time.len()
    }
    fn width(&self) -> usize {
        self.columns.len()
    }
    fn time_at(&self, row: usize) -> f64 {
        self.time[row]
    }
    fn each_in_row(&self, row: usize, mut f: impl FnMut(f64)) {
        for column in &self.columns {
            f(column[row]);
        }
    }
}

impl NumberRows for RecordedRows {
    fn len(&self) -> usize {
        RecordedRows::len(self)
    }
    fn width(&self) -> usize {
        self.names().len()
    }
    fn time_at(&self, row: usize) -> f64 {
        self.time()[row]
    }
    fn each_in_row(&self, row: usize, f: impl FnMut(f64)) {
        self.row(row).iter().copied().for_each(f);
    }
}

/// The rows of a recording without text columns. Numbers never need quotes (digits, `.`,
/// `-`, `e`, `NaN`, `inf`), so the rows are assembled here rather than field by field
/// through the `csv` crate, whose per-field quoting scan cost as much as formatting the
/// numbers (BENCHMARKS.md, round 9); the bytes are the same.
///
/// Blocks of rows (about [`BLOCK_NUMBERS`] numbers each) are formatted on up to
/// [`MOST_FORMAT_THREADS`] cores and
/// written in order: a campaign's last recorded trial is formatted after every trial has
/// run, when the other cores have nothing left to do, and its formatting was most of the
/// time between the last trial's end and the run's (BENCHMARKS.md, round 16). At most two
/// formatted blocks wait per helper thread, so the memory does not grow with the trial.
fn write_number_rows(rec: &impl NumberRows, w: &mut dyn Write) -> io::Result<()> {
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    write_number_rows_on(rec, w, cores.min(MOST_FORMAT_THREADS))
}

/// At most this many threads format one file: a sweep on a large machine runs a writer per
/// job, and a trial's 15 blocks gain little from more, since the writes stay sequential.
const MOST_FORMAT_THREADS: usize = 4;

/// [`write_number_rows`] on at most `threads` threads (the caller's among them).
fn write_number_rows_on(
    rec: &impl NumberRows,
    w: &mut dyn Write,
    threads: usize,
) -> io::Result<()> {
    let rows = block_rows(rec);
    let blocks = rec.len().div_ceil(rows);
    let threads = threads.min(blocks).max(1);
    std::thread::scope(|scope| {
        // Helper h formats blocks h, h + threads, … and sends them in that order; this thread
        // formats the blocks ≡ 0 (mod threads) and writes every block in file order. An
        // error here drops the receivers, which ends the helpers at their next send. Where the
        // system refuses a thread (a user's process limit), this thread formats every block;
        // the helpers already started end the same way.
        let helpers = (1..threads)
            .map(|h| {
                let (full, filled) = sync_channel::<Vec<u8>>(2);
                let (give_back, returned) = sync_channel::<Vec<u8>>(3);
                std::thread::Builder::new()
                    .name("csv-format".into())
                    .spawn_scoped(scope, move || {
                        for block in (h..blocks).step_by(threads) {
                            let mut bytes = returned.try_recv().unwrap_or_default();
                            bytes.clear();
                            format_block(rec, block * rows, rows, &mut bytes);
                            if full.send(bytes).is_err() {
                                return;
                            }
                        }
                    })
                    .map(|_| (filled, give_back))
            })
            .collect::<io::Result<Vec<_>>>()
            .unwrap_or_default();
        let threads = helpers.len() + 1;
        let mut own = Vec::with_capacity(1 << 16);
        for block in 0..blocks {
            match block % threads {
                0 => {
                    own.clear();
                    format_block(rec, block * rows, rows, &mut own);
                    w.write_all(&own)?;
                }
                h => {
                    let (filled, give_back) = &helpers[h - 1];
                    let bytes = filled
                        .recv()
                        .map_err(|_| io::Error::other("a CSV formatting thread stopped"))?;
                    w.write_all(&bytes)?;
                    let _ = give_back.try_send(bytes);
                }
            }
        }
        w.flush()
    })
}

/// Numbers per block of [`write_number_rows`]: at most 24 bytes each, so a block's text stays
/// under 0.8 MB however wide the recording (1,057 rows of the shipped scenarios' 31 numbers).
const BLOCK_NUMBERS: usize = 1 << 15;

/// Rows per block of `rec`: [`BLOCK_NUMBERS`] numbers, at least one row.
fn block_rows(rec: &impl NumberRows) -> usize {
    (BLOCK_NUMBERS / (rec.width() + 1)).max(1)
}

/// Appends the text of at most `rows` rows from row `start` on to `bytes`.
fn format_block(rec: &impl NumberRows, start: usize, rows: usize, bytes: &mut Vec<u8>) {
    let mut numbers = Numbers::default();
    let end = (start + rows).min(rec.len());
    for row in start..end {
        bytes.extend_from_slice(numbers.format(rec.time_at(row)).as_bytes());
        rec.each_in_row(row, |v| {
            bytes.push(b',');
            bytes.extend_from_slice(numbers.format(v).as_bytes());
        });
        bytes.push(b'\n');
    }
}

/// Numbers in the shortest form that parses back to the identical `f64`: positional notation
/// for ordinary magnitudes (1e-5 ≤ |v| < 1e16, and zero) because it is easier to read,
/// scientific for the rest, because positional would spell 1e-300 with 300 zeros; integers
/// without a trailing `.0`, exponents without `+`, and `NaN`, `inf` and `-inf` as Rust
/// spells them.
///
/// `zmij` chooses these digits about 2× faster than `ryu` on the project's machine, which was
/// 2–3× faster than `{}`/`{:e}` of the standard library (formatting is the largest cost of a
/// recorded CSV run, BENCHMARKS.md rounds 3, 9 and 10). It switches between positional and
/// scientific where `{}` and `{:e}` would, so only its `12.0` and `1e+16` need respelling.
/// The text equals the standard library's except where two shortest digit strings are
/// equally close to `v` (a tie is rounded to even, `{}` rounds up: `…511.2` instead of
/// `…511.3` for 1990144188172511.25), and both parse back to `v`; it equals what `ryu`
/// wrote in earlier versions byte for byte (tested).
#[derive(Default)]
struct Numbers {
    digits: zmij::Buffer,
    /// A text without the `+` of its exponent.
    respelled: [u8; 32],
}

impl Numbers {
    fn format(&mut self, v: f64) -> &str {
        if !v.is_finite() {
            return if v.is_nan() {
                "NaN"
            } else if v > 0.0 {
                "inf"
            } else {
                "-inf"
            };
        }
        let text = self.digits.format_finite(v);
        let text = text.strip_suffix(".0").unwrap_or(text);
        // Only a positive exponent has a `+`, followed by its two or three digits (16 to 308)
        // at the end; a scan of the whole text cost as much as choosing the digits.
        let (b, n) = (text.as_bytes(), text.len());
        let plus = if n < 5 {
            None
        } else if b[n - 3] == b'+' {
            Some(n - 3)
        } else if b[n - 4] == b'+' {
            Some(n - 4)
        } else {
            None
        };
        match plus {
            None => text,
            Some(plus) => {
                let (before, after) = (&text[..plus], &text[plus + 1..]);
                let out = &mut self.respelled[..before.len() + after.len()];
                out[..before.len()].copy_from_slice(before.as_bytes());
                out[before.len()..].copy_from_slice(after.as_bytes());
                std::str::from_utf8(out).expect("ASCII digits, sign, point and exponent")
            }
        }
    }
}

/// Writes `rec` to `path` atomically in the format of `exporter`. An inconsistent recording
/// is reported as [`OutputError::Io`] with kind `InvalidData`, and `path` is left untouched.
pub fn write_recording(
    path: &Path,
    rec: &Recording,
    exporter: &dyn Exporter,
) -> Result<(), OutputError> {
    write_atomic(path, |w| exporter.write(rec, w))
}

/// [`write_recording`] of a master's rows, through [`Exporter::write_rows`].
pub fn write_recorded_rows(
    path: &Path,
    rows: &RecordedRows,
    exporter: &dyn Exporter,
) -> Result<(), OutputError> {
    write_atomic(path, |w| exporter.write_rows(rows, w))
}

/// Reads a CSV written by [`CsvExporter`] (used by `--resume` and tests). The first column
/// must be `time`; every field must parse as `f64` (`NaN`, `inf`, `-inf` included). Errors
/// name the file and the 1-based line.
pub fn read_recording_csv(path: &Path) -> Result<Recording, OutputError> {
    let file = File::open(path).map_err(|source| OutputError::Io {
        path: path.to_owned(),
        source,
    })?;
    let mut reader = ReaderBuilder::new()
        .has_headers(true)
        .from_reader(BufReader::new(file));
    let header = reader.headers().map_err(|e| csv_error(path, e))?.clone();
    match header.get(0) {
        Some("time") => {}
        found => {
            return Err(OutputError::Csv {
                path: path.to_owned(),
                line: 1,
                message: match found {
                    Some(f) => format!("first column must be `time`, found {f:?}"),
                    None => "missing header".to_owned(),
                },
            });
        }
    }
    let mut rec = Recording::new(header.iter().skip(1).map(str::to_owned).collect());
    let mut record = StringRecord::new();
    while reader
        .read_record(&mut record)
        .map_err(|e| csv_error(path, e))?
    {
        let line = record.position().map_or(0, |p| p.line());
        let mut fields = header.iter().zip(record.iter()).map(|(name, field)| {
            field.trim().parse::<f64>().map_err(|_| OutputError::Csv {
                path: path.to_owned(),
                line,
                message: format!("column `{name}`: cannot parse {field:?} as a number"),
            })
        });
        // The reader enforces equal field counts, so `fields` yields exactly one value for
        // `time` and one per column.
        if let Some(t) = fields.next() {
            rec.time.push(t?);
        }
        for (column, v) in rec.columns.iter_mut().zip(fields) {
            column.push(v?);
        }
    }
    Ok(rec)
}

fn csv_error(path: &Path, err: ::csv::Error) -> OutputError {
    let line = err.position().map_or(0, |p| p.line());
    if err.is_io_error() {
        if let ErrorKind::Io(source) = err.into_kind() {
            return OutputError::Io {
                path: path.to_owned(),
                source,
            };
        }
        unreachable!("is_io_error implies ErrorKind::Io");
    }
    let message = match err.kind() {
        ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => format!("expected {expected_len} fields, found {len}"),
        _ => err.to_string(),
    };
    OutputError::Csv {
        path: path.to_owned(),
        line,
        message,
    }
}

/// Appends one CSV record to `text`, quoted as [`write_table_csv`] quotes it, for a table
/// that grows a row at a time and is written whole.
pub fn push_csv_record<I, F>(text: &mut Vec<u8>, fields: I) -> io::Result<()>
where
    I: IntoIterator<Item = F>,
    F: AsRef<[u8]>,
{
    let mut out = Writer::from_writer(text);
    out.write_record(fields)?;
    out.flush()
}

/// Writes a summary table atomically: `header`, then `rows`, each quoted as CSV needs. Every
/// row must have as many fields as the header; otherwise nothing is written and the error
/// gives the line the row would have had.
pub fn write_table_csv(
    path: &Path,
    header: &[&str],
    rows: &[Vec<String>],
) -> Result<(), OutputError> {
    if let Some((i, row)) = rows
        .iter()
        .enumerate()
        .find(|(_, r)| r.len() != header.len())
    {
        return Err(OutputError::Csv {
            path: path.to_owned(),
            line: i as u64 + 2,
            message: format!(
                "row {i} has {} fields, header has {}",
                row.len(),
                header.len()
            ),
        });
    }
    write_atomic(path, |w| {
        let mut out = Writer::from_writer(w);
        out.write_record(header)?;
        for row in rows {
            out.write_record(row)?;
        }
        out.flush()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    const AWKWARD: [f64; 16] = [
        1e-300,
        -0.0,
        0.0,
        0.1 + 0.2,
        f64::MAX,
        f64::MIN,
        f64::MIN_POSITIVE,
        5e-324,
        2.225e-310,
        -1.5e-320,
        1e16,
        9_007_199_254_740_993.0,
        123_456.789_012_345_67,
        1e-5,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];

    /// A table grown a record at a time is the file `write_table_csv` writes, quoting and
    /// line ends included (summary.csv is written the first way, the study's tables the other).
    #[test]
    fn records_pushed_one_at_a_time_make_the_written_table() {
        let dir = tempfile::tempdir().unwrap();
        let header = ["trial", "note, with comma", "empty"];
        let rows = vec![
            vec!["0".to_string(), "say \"hi\"".into(), String::new()],
            vec!["1".to_string(), "two\nlines".into(), "1e-300".into()],
        ];
        let path = dir.path().join("t.csv");
        write_table_csv(&path, &header, &rows).unwrap();
        let mut text = Vec::new();
        push_csv_record(&mut text, header).unwrap();
        for row in &rows {
            push_csv_record(&mut text, row).unwrap();
        }
        assert_eq!(text, fs::read(&path).unwrap());
    }

    /// A format that does not read the rows itself writes them as their recording: the
    /// text-column CSV without text columns is the plain CSV, byte for byte.
    #[test]
    fn rows_written_through_their_recording_are_the_plain_csv() {
        let mut rows = RecordedRows::with_capacity(vec!["a".into(), "b[1]".into()], 3);
        rows.push(0.0, &[1.5, -2.0]);
        rows.push(0.001, &[1e-300, f64::INFINITY]);
        let (mut plain, mut through) = (Vec::new(), Vec::new());
        CsvExporter.write_rows(&rows, &mut plain).unwrap();
        let text = CsvWithText::default();
        text.write_rows(&rows, &mut through).unwrap();
        assert_eq!(
            String::from_utf8(through).unwrap(),
            String::from_utf8(plain.clone()).unwrap()
        );
        assert_eq!(text.extension(), CsvExporter.extension());
        // The file a campaign writes holds those bytes, and reads back as the recording.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("trial.csv");
        write_recorded_rows(&path, &rows, &CsvExporter).unwrap();
        assert_eq!(fs::read(&path).unwrap(), plain);
        assert_eq!(read_recording_csv(&path).unwrap(), rows.to_recording());
    }

    /// A text column replaces its numeric column, quoted where it must be; the others are
    /// numbers as in the plain CSV. Text columns that do not fit the recording are refused.
    #[test]
    fn text_columns_replace_their_numbers_and_must_fit() {
        let rec = Recording {
            time: vec![0.0, 0.5],
            names: vec!["x".into(), "label".into(), "y".into()],
            columns: vec![vec![1.0, 2.5], vec![9.0, 9.0], vec![-0.25, 1e-300]],
        };
        let text = CsvWithText {
            text: vec![(1, vec!["plain".into(), "a, \"quoted\" one".into()])],
        };
        let mut out = Vec::new();
        text.write(&rec, &mut out).unwrap();
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "time,x,label,y\n0,1,plain,-0.25\n0.5,2.5,\"a, \"\"quoted\"\" one\",1e-300\n"
        );
        for (column, rows) in [(3, 2), (1, 1), (1, 3)] {
            let bad = CsvWithText {
                text: vec![(column, vec![String::new(); rows])],
            };
            let err = bad.write(&rec, &mut Vec::new()).unwrap_err();
            assert_eq!(err.kind(), io::ErrorKind::InvalidData);
            assert_eq!(
                err.to_string(),
                format!("text column {column} has {rows} rows for 3 columns of 2 rows")
            );
        }
    }

    fn formatted(v: f64) -> String {
        Numbers::default().format(v).to_owned()
    }

    /// What the CSV files held while `ryu` formatted them: the same bytes are still written.
    fn ryu_formatted(v: f64) -> String {
        if !v.is_finite() {
            return formatted(v);
        }
        let mut buf = ryu::Buffer::new();
        let text = buf.format_finite(v);
        text.strip_suffix(".0").unwrap_or(text).to_owned()
    }

    /// The standard library's shortest round-trip text, switched between `{}` and `{:e}` at
    /// the magnitudes [`Numbers`] documents: the spelling the CSV files had before `ryu`.
    fn std_formatted(v: f64) -> String {
        let m = v.abs();
        if m == 0.0 || !v.is_finite() || (1e-5..1e16).contains(&m) {
            format!("{v}")
        } else {
            format!("{v:e}")
        }
    }

    /// Every awkward value, 10^6 pseudo-random bit patterns and small magnitudes, subnormals,
    /// the powers of ten and integers small and large: the text equals what `ryu` wrote,
    /// parses back to the same bits and equals the standard library's, except in a tie
    /// between two equally close shortest digit strings, where it has the same length.
    #[test]
    fn numbers_match_the_standard_library_and_round_trip() {
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut values: Vec<f64> = AWKWARD.to_vec();
        values.extend((-323..=308).map(|e| format!("1e{e}").parse::<f64>().unwrap()));
        values.extend((0..64).map(|b| 2f64.powi(b)));
        values.extend((-2000..2000).map(f64::from));
        values.extend((1..2000_u64).map(|m| f64::from_bits(m * 0x1_0000_0001)));
        for i in 0..1_000_000_u32 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            values.push(match i % 3 {
                0 => f64::from_bits(x),
                1 => (x >> 11) as f64 * 2f64.powi(-53) * 10f64.powi((i % 40) as i32 - 20),
                _ => (x % 2_000_000) as f64 * 1e-3,
            });
        }
        let mut ties = 0;
        for v in values {
            let ours = formatted(v);
            assert_eq!(ours, ryu_formatted(v), "{v:e}");
            let std = std_formatted(v);
            if v.is_nan() {
                assert_eq!(ours, "NaN");
                continue;
            }
            let back: f64 = ours.parse().unwrap();
            assert_eq!(back.to_bits(), v.to_bits(), "{ours} for {v:e}");
            if ours != std {
                ties += 1;
                assert_eq!(ours.len(), std.len(), "{ours} against {std}");
                assert!(!ours.contains('e') || ours.split('e').nth(1) == std.split('e').nth(1));
            }
        }
        // Ties exist only where the 17th digit is needed (about 1 in 1000 random patterns).
        assert!(ties < 2_000, "{ties} ties");
    }

    #[test]
    fn numbers_are_short_and_readable() {
        assert_eq!(formatted(0.001), "0.001");
        assert_eq!(formatted(0.1 + 0.2), "0.30000000000000004");
        assert_eq!(formatted(1e-300), "1e-300");
        assert_eq!(formatted(-0.0), "-0");
        assert_eq!(formatted(f64::MAX), "1.7976931348623157e308");
        assert_eq!(formatted(f64::NAN), "NaN");
        assert_eq!(formatted(f64::NEG_INFINITY), "-inf");
        assert_eq!(formatted(12.0), "12");
        assert_eq!(formatted(1e16), "1e16");
        assert_eq!(formatted(9.99e-6), "9.99e-6");
    }

    #[test]
    fn csv_round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("trial.csv");
        let names = vec!["a".to_owned(), "b, \"quoted\"".to_owned(), "nan".to_owned()];
        let mut rec = Recording::with_capacity(names, AWKWARD.len());
        for (i, &v) in AWKWARD.iter().enumerate() {
            rec.push_row(i as f64 * 1e-3, &[v, -v, f64::NAN]);
        }
        write_recording(&path, &rec, &CsvExporter).unwrap();
        let back = read_recording_csv(&path).unwrap();
        assert_eq!(back.names, rec.names);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.time), bits(&rec.time));
        assert_eq!(bits(&back.columns[0]), bits(&rec.columns[0]));
        assert_eq!(bits(&back.columns[1]), bits(&rec.columns[1]));
        assert!(back.columns[2].iter().all(|v| v.is_nan()));
        assert_eq!(back.len(), AWKWARD.len());
        let text = fs::read_to_string(&path).unwrap();
        assert!(
            text.starts_with("time,a,\"b, \"\"quoted\"\"\",nan\n"),
            "{text}"
        );
    }

    #[test]
    fn empty_recording_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.csv");
        let rec = Recording::new(vec!["x".into()]);
        write_recording(&path, &rec, &CsvExporter).unwrap();
        assert_eq!(read_recording_csv(&path).unwrap(), rec);
    }

    #[test]
    fn malformed_number_names_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.csv");
        fs::write(&path, "time,a\n0,1\n0.001,oops\n").unwrap();
        let err = read_recording_csv(&path).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("bad.csv:3:"), "{msg}");
        assert!(msg.contains("oops"), "{msg}");
        assert!(matches!(err, OutputError::Csv { line: 3, .. }));
    }

    #[test]
    fn short_row_names_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("short.csv");
        fs::write(&path, "time,a,b\n0,1,2\n0.001,3,4\n0.002,5\n").unwrap();
        let err = read_recording_csv(&path).unwrap_err();
        assert!(err.to_string().contains("short.csv:4:"), "{err}");
        assert!(
            err.to_string().contains("expected 3 fields, found 2"),
            "{err}"
        );
        fs::write(&path, "time,a,b\n0,1\n").unwrap();
        let err = read_recording_csv(&path).unwrap_err();
        assert!(matches!(err, OutputError::Csv { line: 2, .. }), "{err}");
    }

    #[test]
    fn header_must_start_with_time() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.csv");
        fs::write(&path, "t,a\n0,1\n").unwrap();
        let err = read_recording_csv(&path).unwrap_err();
        assert!(matches!(err, OutputError::Csv { line: 1, .. }), "{err}");
        fs::write(&path, "").unwrap();
        let err = read_recording_csv(&path).unwrap_err();
        assert!(err.to_string().contains("missing header"), "{err}");
    }

    #[test]
    fn missing_file_is_io_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("absent.csv");
        let err = read_recording_csv(&path).unwrap_err();
        assert!(matches!(err, OutputError::Io { .. }));
        assert!(err.to_string().contains("absent.csv"), "{err}");
    }

    #[test]
    fn inconsistent_recording_is_rejected_and_old_file_kept() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        fs::write(&path, "old").unwrap();
        let mut rec = Recording::new(vec!["a".into()]);
        rec.push_row(0.0, &[1.0]);
        rec.time.push(0.001);
        let err = write_recording(&path, &rec, &CsvExporter).unwrap_err();
        let OutputError::Io { source, .. } = &err else {
            panic!("{err:?}")
        };
        assert_eq!(source.kind(), io::ErrorKind::InvalidData);
        assert_eq!(fs::read_to_string(&path).unwrap(), "old");
        assert_eq!(CsvExporter.extension(), "csv");
    }

    #[test]
    fn table_csv_writes_and_validates() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("summary.csv");
        let rows = vec![
            vec!["pid".to_owned(), "1.5".to_owned()],
            vec!["a,b".to_owned(), String::new()],
        ];
        write_table_csv(&path, &["scheme", "rms_mm"], &rows).unwrap();
        assert_eq!(
            fs::read_to_string(&path).unwrap(),
            "scheme,rms_mm\npid,1.5\n\"a,b\",\n"
        );
        let bad = vec![vec!["x".to_owned()]];
        let err = write_table_csv(&path, &["scheme", "rms_mm"], &bad).unwrap_err();
        assert!(err.to_string().contains("summary.csv:2:"), "{err}");
        assert!(
            fs::read_to_string(&path)
                .unwrap()
                .starts_with("scheme,rms_mm\npid")
        );
    }

    /// The rows assembled by hand are the bytes the `csv` crate writes field by field, on
    /// every awkward value, over many buffer flushes, with no columns and with names that
    /// need quotes.
    #[test]
    fn hand_assembled_rows_equal_the_csv_crate_s() {
        let oracle = |rec: &Recording| {
            let mut out = Writer::from_writer(Vec::new());
            out.write_field("time").unwrap();
            for name in &rec.names {
                out.write_field(name).unwrap();
            }
            out.write_record(None::<&[u8]>).unwrap();
            for (row, &t) in rec.time.iter().enumerate() {
                out.write_field(ryu_formatted(t)).unwrap();
                for column in &rec.columns {
                    out.write_field(ryu_formatted(column[row])).unwrap();
                }
                out.write_record(None::<&[u8]>).unwrap();
            }
            out.into_inner().unwrap()
        };
        let names = vec![
            "a".to_string(),
            "b, \"quoted\"".to_string(),
            "c".to_string(),
        ];
        let mut wide = Recording::with_capacity(names, 0);
        for i in 0..20_000 {
            let v = AWKWARD[i % AWKWARD.len()];
            wide.push_row(i as f64 * 1e-3, &[v, -v, v * 1e-3]);
        }
        let mut empty = Recording::with_capacity(Vec::new(), 0);
        for i in 0..3 {
            empty.push_row(f64::from(i), &[]);
        }
        for rec in [&wide, &empty] {
            let mut ours = Vec::new();
            CsvExporter.write(rec, &mut ours).unwrap();
            assert!(ours == oracle(rec), "{} columns", rec.names.len());
        }
        // The same bytes on any number of formatting threads: 20,000 rows of four numbers are
        // 3 blocks of 8,192 rows, the last one short, dealt to 1, 2, 3, 7 and more threads
        // than blocks.
        assert_eq!(wide.len().div_ceil(block_rows(&wide)), 3);
        let expected = oracle(&wide);
        let header = expected.iter().position(|&b| b == b'\n').unwrap() + 1;
        for threads in [1, 2, 3, 7, 64] {
            let mut rows = Vec::new();
            write_number_rows_on(&wide, &mut rows, threads).unwrap();
            assert!(rows == expected[header..], "{threads} threads");
        }
    }

    /// A master's rows written as they are: the bytes of the same signals as columns, on
    /// every awkward value, over several blocks and formatting threads, with names that need
    /// quotes and with no columns.
    #[test]
    fn rows_write_the_bytes_of_their_columns() {
        let names = vec!["a".to_string(), "b, \"quoted\"".to_string()];
        let mut wide = RecordedRows::with_capacity(names, 0);
        for i in 0..30_000 {
            let v = AWKWARD[i % AWKWARD.len()];
            wide.push(i as f64 * 1e-3, &[v, -v * 1e-7]);
        }
        let mut empty = RecordedRows::with_capacity(Vec::new(), 0);
        for i in 0..3 {
            empty.push(f64::from(i), &[]);
        }
        for rows in [&wide, &empty] {
            let mut ours = Vec::new();
            CsvExporter.write_rows(rows, &mut ours).unwrap();
            let mut theirs = Vec::new();
            CsvExporter
                .write(&rows.to_recording(), &mut theirs)
                .unwrap();
            assert!(ours == theirs, "{} columns", rows.names().len());
        }
        assert_eq!(wide.len().div_ceil(block_rows(&wide)), 3);
        let columns = wide.to_recording();
        for threads in [1, 2, 3, 64] {
            let (mut ours, mut theirs) = (Vec::new(), Vec::new());
            write_number_rows_on(&wide, &mut ours, threads).unwrap();
            write_number_rows_on(&columns, &mut theirs, threads).unwrap();
            assert!(ours == theirs, "{threads} threads");
        }
    }

    /// A sink that fails part-way stops the formatting threads and reports its error, on one
    /// thread and on several, wherever in the file it fails.
    #[test]
    fn a_failing_sink_stops_the_formatting_threads() {
        struct FailsAfter(usize);
        impl Write for FailsAfter {
            fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
                if buf.len() > self.0 {
                    return Err(io::Error::other("disk full"));
                }
                self.0 -= buf.len();
                Ok(buf.len())
            }
            fn flush(&mut self) -> io::Result<()> {
                Ok(())
            }
        }
        // 16 columns: 1,927 rows per block, six blocks.
        let names = (0..16).map(|c| format!("c{c}")).collect();
        let mut rec = Recording::with_capacity(names, 0);
        for i in 0..10_000 {
            let x = f64::from(i) * 0.1;
            let row: Vec<f64> = (0..16).map(|c| (x + f64::from(c)).sin()).collect();
            rec.push_row(x * 1e-2, &row);
        }
        assert_eq!(rec.len().div_ceil(block_rows(&rec)), 6);
        let mut all = Vec::new();
        write_number_rows_on(&rec, &mut all, 1).unwrap();
        for threads in [1, 2, 4] {
            for fail_at in [0, 1, all.len() / 3, all.len() - 1] {
                let err = write_number_rows_on(&rec, &mut FailsAfter(fail_at), threads)
                    .expect_err("the sink failed");
                assert_eq!(err.to_string(), "disk full", "{threads} threads");
            }
        }
    }
}
