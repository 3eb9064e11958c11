//! In-memory signals of one trial: column-major for plots, norms and the exporters, which
//! read whole signals, and row-major as the master loop writes them, one row per 1 ms step.

use std::ops::Range;

/// One trial's recorded signals: a time column plus named columns of equal length.
///
/// The fields are public for cheap read access; code that builds a recording field by field
/// must keep every column as long as `time` (exporters reject inconsistent recordings).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Recording {
    /// Sample times in s.
    pub time: Vec<f64>,
    /// Column names, without the leading `time`.
    pub names: Vec<String>,
    /// One vector per name, each as long as `time`.
    pub columns: Vec<Vec<f64>>,
}

impl Recording {
    /// An empty recording with the given column names.
    pub fn new(names: Vec<String>) -> Self {
        Self::with_capacity(names, 0)
    }

    /// An empty recording with room for `rows` rows in every column, so that a trial of known
    /// length never reallocates inside the stepping loop.
    pub fn with_capacity(names: Vec<String>, rows: usize) -> Self {
        let columns = names.iter().map(|_| Vec::with_capacity(rows)).collect();
        Self {
            time: Vec::with_capacity(rows),
            names,
            columns,
        }
    }

    /// Appends one row. Allocates nothing when the capacity suffices.
    ///
    /// # Panics
    /// If `values.len()` differs from the number of columns: a silently short or long row
    /// would shift every later signal.
    pub fn push_row(&mut self, t: f64, values: &[f64]) {
        assert_eq!(
            values.len(),
            self.columns.len(),
            "Recording::push_row: {} values for {} columns",
            values.len(),
            self.columns.len()
        );
        self.time.push(t);
        for (column, &v) in self.columns.iter_mut().zip(values) {
            column.push(v);
        }
    }

    /// The column called `name` (the first one if names repeat), or `None`. `"time"` is not a
    /// column here; use the `time` field.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        let i = self.names.iter().position(|n| n == name)?;
        self.columns.get(i).map(Vec::as_slice)
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// Describes the first inconsistency between the fields, if any.
    pub(crate) fn shape_error(&self) -> Option<String> {
        if self.names.len() != self.columns.len() {
            return Some(format!(
                "{} names but {} columns",
                self.names.len(),
                self.columns.len()
            ));
        }
        self.names
            .iter()
            .zip(&self.columns)
            .find(|(_, c)| c.len() != self.time.len())
            .map(|(n, c)| {
                format!(
                    "column `{n}` has {} rows, time has {}",
                    c.len(),
                    self.time.len()
                )
            })
    }
}

/// One trial's recorded signals as the master loop writes them: row-major, so that a step
/// appends one contiguous row and nothing else, as the FMI-free floor the co-simulation is
/// measured against does. Moving rows into columns inside the loop cost a recorded trial
/// 3–4 % of its time (BENCHMARKS.md, round 31). `run`'s writer threads export the rows as
/// they are ([`crate::output::Exporter::write_rows`]), while the next trial steps; plots and
/// norms read the columns of [`RecordedRows::to_recording`].
///
/// The rows are kept in blocks of at most [`BLOCK_VALUES`] values rather than in one buffer
/// for the trial: glibc serves a request that large from `mmap`, and once such a block is
/// freed it raises its threshold and takes the next ones from its per-thread heaps, which
/// fragment. With one 3.7 MB buffer per trial, `paper --jobs 4` peaked 5–10 MB higher
/// (BENCHMARKS.md, round 31); the blocks are as large as a column of the columnar recording.
#[derive(Debug, Clone, Default)]
pub struct RecordedRows {
    names: Vec<String>,
    time: Vec<f64>,
    /// The rows in order, [`block_rows`] to a block; the blocks after the one
    /// being filled are empty (room kept from an earlier trial or reserved up front).
    blocks: Vec<Vec<f64>>,
    /// The block being filled: the row count over [`block_rows`], kept so that a push
    /// needs no division.
    filling: usize,
}

/// Most values in one block of [`RecordedRows`]: 120 KiB, under glibc's initial 128 KiB
/// `mmap` threshold.
const BLOCK_VALUES: usize = 15 * 1024;

/// Rows per block when reordering into columns: each column then takes 64 consecutive values
/// from a block of rows that stays in the L1 cache (64 rows of 32 columns are 16 KiB).
const TRANSPOSE_ROWS: usize = 64;

impl RecordedRows {
    /// Empty rows of the given column names, with room for `rows` rows, so that a trial of
    /// known length never allocates inside the stepping loop.
    pub fn with_capacity(names: Vec<String>, rows: usize) -> Self {
        let per_block = block_rows(names.len());
        let values = per_block * names.len();
        Self {
            time: Vec::with_capacity(rows),
            blocks: (0..rows.div_ceil(per_block).max(1))
                .map(|_| Vec::with_capacity(values))
                .collect(),
            filling: 0,
            names,
        }
    }

    /// Column names, without the leading `time`.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Sample times in s.
    pub fn time(&self) -> &[f64] {
        &self.time
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// Row `i`'s values, one per name.
    ///
    /// # Panics
    /// If `i` is not below [`RecordedRows::len`].
    pub fn row(&self, i: usize) -> &[f64] {
        assert!(i < self.len(), "row {i} of {}", self.len());
        let width = self.names.len();
        if width == 0 {
            return &[];
        }
        let per_block = block_rows(width);
        let at = i % per_block * width;
        &self.blocks[i / per_block][at..at + width]
    }

    /// Every row in order, one per time.
    pub fn rows(&self) -> impl Iterator<Item = &[f64]> {
        let width = self.names.len();
        // Rows without values are not in the blocks: one empty row per time.
        let empty = if width == 0 { self.len() } else { 0 };
        self.blocks
            .iter()
            .flat_map(move |b| b.chunks_exact(width.max(1)))
            .chain(std::iter::repeat_n(&[][..], empty))
    }

    /// Appends one row. Allocates nothing when the capacity suffices.
    ///
    /// # Panics
    /// If `values.len()` differs from the number of names, as [`Recording::push_row`].
    #[inline]
    pub fn push(&mut self, t: f64, values: &[f64]) {
        assert_eq!(
            values.len(),
            self.names.len(),
            "RecordedRows::push: {} values for {} columns",
            values.len(),
            self.names.len()
        );
        let full = self
            .blocks
            .get(self.filling)
            .is_none_or(|b| b.len() + values.len() > b.capacity());
        if full {
            self.next_block();
        }
        self.blocks[self.filling].extend_from_slice(values);
        self.time.push(t);
    }

    /// Moves on to the next block, reserving it if there is none.
    #[cold]
    fn next_block(&mut self) {
        if !self.blocks.is_empty() {
            self.filling += 1;
        }
        if self.filling == self.blocks.len() {
            let values = block_rows(self.names.len()) * self.names.len();
            self.blocks.push(Vec::with_capacity(values));
        }
    }

    /// Drops every row and keeps the capacity.
    pub fn clear(&mut self) {
        self.time.clear();
        for b in &mut self.blocks {
            b.clear();
        }
        self.filling = 0;
    }

    /// The same signals as a column-major [`Recording`].
    pub fn to_recording(&self) -> Recording {
        Recording {
            time: self.time.clone(),
            names: self.names.clone(),
            columns: self.columns(0..self.names.len()),
        }
    }

    /// The columns `range` (by index into [`RecordedRows::names`]), each as long as the
    /// rows.
    ///
    /// # Panics
    /// If `range` reaches past the last column.
    pub fn columns(&self, range: Range<usize>) -> Vec<Vec<f64>> {
        assert!(
            range.end <= self.names.len(),
            "columns {range:?} of {}",
            self.names.len()
        );
        let width = self.names.len();
        let mut columns: Vec<Vec<f64>> = range
            .clone()
            .map(|_| Vec::with_capacity(self.len()))
            .collect();
        if range.is_empty() {
            return columns;
        }
        // A few rows at a time, so each row's cache lines are read once, not once per
        // column.
        for rows in self
            .blocks
            .iter()
            .flat_map(|b| b.chunks(TRANSPOSE_ROWS * width))
        {
            for (c, column) in range.clone().zip(&mut columns) {
                column.extend(rows.chunks_exact(width).map(|row| row[c]));
            }
        }
        columns
    }
}

/// Rows per block of [`RecordedRows`] of `width` columns: as many as [`BLOCK_VALUES`] holds,
/// at least one.
fn block_rows(width: usize) -> usize {
    (BLOCK_VALUES / width.max(1)).max(1)
}

/// Equal names, times and rows, however the rows are laid out in blocks.
impl PartialEq for RecordedRows {
    fn eq(&self, other: &Self) -> bool {
        self.names == other.names && self.time == other.time && self.rows().eq(other.rows())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names() -> Vec<String> {
        vec!["a".into(), "b".into()]
    }

    #[test]
    fn push_and_lookup() {
        let mut r = Recording::new(names());
        assert!(r.is_empty());
        r.push_row(0.0, &[1.0, 2.0]);
        r.push_row(0.001, &[3.0, 4.0]);
        assert_eq!(r.len(), 2);
        assert_eq!(r.column("b"), Some(&[2.0, 4.0][..]));
        assert_eq!(r.column("time"), None);
        assert_eq!(r.shape_error(), None);
    }

    #[test]
    fn with_capacity_does_not_reallocate() {
        let mut r = Recording::with_capacity(names(), 100);
        let before: Vec<*const f64> = r.columns.iter().map(|c| c.as_ptr()).collect();
        let time_before = r.time.as_ptr();
        for i in 0..100 {
            r.push_row(f64::from(i), &[0.0, 1.0]);
        }
        let after: Vec<*const f64> = r.columns.iter().map(|c| c.as_ptr()).collect();
        assert_eq!(before, after);
        assert_eq!(time_before, r.time.as_ptr());
    }

    #[test]
    #[should_panic(expected = "1 values for 2 columns")]
    fn push_row_rejects_wrong_width() {
        Recording::new(names()).push_row(0.0, &[1.0]);
    }

    #[test]
    fn shape_error_reports_short_column() {
        let mut r = Recording::new(names());
        r.push_row(0.0, &[1.0, 2.0]);
        r.columns[1].pop();
        assert_eq!(
            r.shape_error().as_deref(),
            Some("column `b` has 0 rows, time has 1")
        );
    }

    /// Rows reordered into columns, over several blocks and a partial one (of storage and
    /// of the reordering), equal the same rows pushed into a recording one by one; rows read
    /// back one by one and in order are the rows pushed.
    #[test]
    fn rows_make_the_recording_of_the_same_rows() {
        let names: Vec<String> = (0..3).map(|c| format!("c{c}")).collect();
        let mut direct = Recording::new(names.clone());
        // Room for 4 rows: the blocks past the first are reserved as the rows come.
        let mut rows = RecordedRows::with_capacity(names.clone(), 4);
        let per_block = BLOCK_VALUES / 3;
        let n = 2 * per_block + TRANSPOSE_ROWS + 5;
        let row_of = |i: usize| [i as f64 * 1e-3, -(i as f64), 0.5 * i as f64];
        for i in 0..n {
            direct.push_row(row_of(i)[0], &row_of(i));
            rows.push(row_of(i)[0], &row_of(i));
        }
        assert_eq!(rows.len(), n);
        assert_eq!(rows.blocks.len(), 3);
        for i in [0, 7, per_block - 1, per_block, 2 * per_block, n - 1] {
            assert_eq!(rows.row(i), row_of(i), "row {i}");
        }
        assert!(
            rows.rows().eq((0..n)
                .map(row_of)
                .collect::<Vec<_>>()
                .iter()
                .map(|r| &r[..]))
        );
        let rec = rows.to_recording();
        assert_eq!(rec, direct);
        assert_eq!(rec.shape_error(), None);
        // The same rows with room for all of them up front: laid out alike, and equal.
        let mut roomy = RecordedRows::with_capacity(names, n);
        for i in 0..n {
            roomy.push(row_of(i)[0], &row_of(i));
        }
        assert_eq!(roomy, rows);
        roomy.push(1.0, &[0.0; 3]);
        assert_ne!(roomy, rows);
    }

    /// Rows without columns still keep their times, and read as empty rows.
    #[test]
    fn rows_without_columns_keep_their_times() {
        let mut rows = RecordedRows::with_capacity(Vec::new(), 0);
        for i in 0..3 {
            rows.push(f64::from(i), &[]);
        }
        assert_eq!(rows.row(2), [0.0; 0]);
        assert_eq!(rows.rows().count(), 3);
        let rec = rows.to_recording();
        assert_eq!(rec.time, [0.0, 1.0, 2.0]);
        assert!(rec.columns.is_empty());
    }

    /// A trial after the first reuses the blocks: nothing is reserved again.
    #[test]
    fn cleared_rows_keep_their_blocks() {
        let width = 40;
        let per_block = BLOCK_VALUES / width;
        let mut rows = RecordedRows::with_capacity(vec![String::new(); width], 2 * per_block);
        let fill = |rows: &mut RecordedRows| {
            for i in 0..2 * per_block {
                rows.push(i as f64, &vec![i as f64; width]);
            }
        };
        let at = |rows: &RecordedRows| rows.blocks.iter().map(|b| b.as_ptr()).collect::<Vec<_>>();
        let before = at(&rows);
        fill(&mut rows);
        rows.clear();
        assert!(rows.is_empty());
        fill(&mut rows);
        assert_eq!(at(&rows), before);
        assert_eq!(rows.row(per_block), [per_block as f64; 40]);
        assert!(
            rows.to_recording()
                .columns
                .iter()
                .all(|c| c.len() == 2 * per_block)
        );
    }

    #[test]
    #[should_panic(expected = "columns 1..3 of 2")]
    fn columns_past_the_last_are_refused() {
        RecordedRows::with_capacity(names(), 1).columns(1..3);
    }

    #[test]
    #[should_panic(expected = "row 1 of 1")]
    fn rows_past_the_end_are_refused() {
        let mut rows = RecordedRows::with_capacity(names(), 1);
        rows.push(0.0, &[1.0, 2.0]);
        rows.row(1);
    }

    #[test]
    #[should_panic(expected = "1 values for 2 columns")]
    fn rows_reject_wrong_width() {
        RecordedRows::with_capacity(names(), 1).push(0.0, &[1.0]);
    }
}
