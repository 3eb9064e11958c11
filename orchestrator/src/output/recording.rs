//! In-memory signals of one trial: column-major for plots, norms and the exporters, which
//! read whole signals, and row-major as the master loop writes them, one row per 1 ms step.

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
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RecordedRows {
    names: Vec<String>,
    time: Vec<f64>,
    /// Row `i` is `values[i * width..(i + 1) * width]`, `width` being `names.len()`.
    values: Vec<f64>,
}

/// Rows per block when reordering into columns: each column then takes 64 consecutive values
/// from a block of rows that stays in the L1 cache (64 rows of 32 columns are 16 KiB).
const BLOCK_ROWS: usize = 64;

impl RecordedRows {
    /// Empty rows of the given column names, with room for `rows` rows, so that a trial of
    /// known length never reallocates inside the stepping loop.
    pub fn with_capacity(names: Vec<String>, rows: usize) -> Self {
        Self {
            time: Vec::with_capacity(rows),
            values: Vec::with_capacity(rows * names.len()),
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
        let width = self.names.len();
        &self.values[i * width..(i + 1) * width]
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
        self.time.push(t);
        self.values.extend_from_slice(values);
    }

    /// Drops every row and keeps the capacity.
    pub fn clear(&mut self) {
        self.time.clear();
        self.values.clear();
    }

    /// The same signals as a column-major [`Recording`].
    pub fn to_recording(&self) -> Recording {
        let mut rec = Recording::with_capacity(self.names.clone(), self.len());
        rec.time.extend_from_slice(&self.time);
        let width = self.names.len();
        if width > 0 {
            // A block of rows at a time, so each row's cache lines are read once, not once
            // per column.
            for block in self.values.chunks(BLOCK_ROWS * width) {
                for (c, column) in rec.columns.iter_mut().enumerate() {
                    column.extend(block.chunks_exact(width).map(|row| row[c]));
                }
            }
        }
        rec
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

    /// Rows reordered into columns, over several blocks and a partial one, equal the same
    /// rows pushed into a recording one by one.
    #[test]
    fn rows_make_the_recording_of_the_same_rows() {
        let names: Vec<String> = (0..3).map(|c| format!("c{c}")).collect();
        let mut direct = Recording::new(names.clone());
        let mut rows = RecordedRows::with_capacity(names, 4);
        let n = 2 * BLOCK_ROWS + 5;
        for i in 0..n {
            let t = i as f64 * 1e-3;
            let row = [t, -(i as f64), 0.5 * i as f64];
            direct.push_row(t, &row);
            rows.push(t, &row);
        }
        assert_eq!(rows.len(), n);
        assert_eq!(rows.row(7), [7e-3, -7.0, 3.5]);
        let rec = rows.to_recording();
        assert_eq!(rec, direct);
        assert_eq!(rec.shape_error(), None);
    }

    /// Rows without columns still keep their times.
    #[test]
    fn rows_without_columns_keep_their_times() {
        let mut rows = RecordedRows::with_capacity(Vec::new(), 0);
        for i in 0..3 {
            rows.push(f64::from(i), &[]);
        }
        let rec = rows.to_recording();
        assert_eq!(rec.time, [0.0, 1.0, 2.0]);
        assert!(rec.columns.is_empty());
    }

    #[test]
    fn cleared_rows_keep_their_capacity() {
        let mut rows = RecordedRows::with_capacity(names(), 10);
        let before = rows.values.as_ptr();
        rows.push(0.0, &[1.0, 2.0]);
        rows.clear();
        assert!(rows.is_empty());
        for i in 0..10 {
            rows.push(f64::from(i), &[1.0, 2.0]);
        }
        assert_eq!(before, rows.values.as_ptr());
        assert!(rows.to_recording().columns.iter().all(|c| c.len() == 10));
    }

    #[test]
    #[should_panic(expected = "1 values for 2 columns")]
    fn rows_reject_wrong_width() {
        RecordedRows::with_capacity(names(), 1).push(0.0, &[1.0]);
    }
}
