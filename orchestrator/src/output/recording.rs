//! In-memory signals of one trial, kept column-major because plots and norms read whole
//! signals while the master loop appends one row per 1 ms step.

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

/// Rows staged row-major before they reach a [`Recording`]'s columns in blocks.
///
/// Appending a row straight to the columns stores into one cache line per column, every
/// row, and on a trial-sized recording those lines are rarely cached: the stores stall the
/// master loop. Here a row is one sequential copy into a buffer that stays in L1, and each
/// full block is moved into the columns a column at a time, 64 consecutive values each:
/// 2 to 4 % less CPU per recorded trial (BENCHMARKS.md, round 19).
#[derive(Debug, Clone)]
pub(crate) struct RowStage {
    width: usize,
    time: Vec<f64>,
    values: Vec<f64>,
}

impl RowStage {
    /// Rows per block: 64 rows of a 32-column recording take 16 KiB.
    pub const ROWS: usize = 64;

    /// An empty stage for rows of `width` values; allocates its block here, once.
    pub fn new(width: usize) -> Self {
        Self {
            width,
            time: Vec::with_capacity(Self::ROWS),
            values: Vec::with_capacity(Self::ROWS * width),
        }
    }

    /// Stages one row, moving the block into `rec` when it is full.
    ///
    /// # Panics
    /// If `values.len()` differs from the stage's width, as [`Recording::push_row`].
    #[inline]
    pub fn push(&mut self, t: f64, values: &[f64], rec: &mut Recording) {
        assert_eq!(
            values.len(),
            self.width,
            "RowStage::push: {} values for {} columns",
            values.len(),
            self.width
        );
        self.time.push(t);
        self.values.extend_from_slice(values);
        if self.time.len() == Self::ROWS {
            self.flush(rec);
        }
    }

    /// Moves every staged row into `rec` and empties the stage. Call it when the rows end,
    /// on failure too: until then the last rows are only here.
    ///
    /// # Panics
    /// If `rec` has a different number of columns than the stage's width.
    pub fn flush(&mut self, rec: &mut Recording) {
        assert_eq!(
            rec.columns.len(),
            self.width,
            "RowStage::flush: {} columns in the recording, rows of {}",
            rec.columns.len(),
            self.width
        );
        if self.time.is_empty() {
            return;
        }
        rec.time.extend_from_slice(&self.time);
        if self.width > 0 {
            for (c, column) in rec.columns.iter_mut().enumerate() {
                column.extend(self.values[c..].iter().step_by(self.width));
            }
        }
        self.clear();
    }

    /// Drops the staged rows without moving them anywhere.
    pub fn clear(&mut self) {
        self.time.clear();
        self.values.clear();
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

    /// Rows through the stage, in blocks and a partial block, equal the same rows pushed
    /// one by one.
    #[test]
    fn staged_rows_equal_rows_pushed_directly() {
        let names: Vec<String> = (0..3).map(|c| format!("c{c}")).collect();
        let mut direct = Recording::new(names.clone());
        let mut staged = Recording::new(names);
        let mut stage = RowStage::new(3);
        let rows = 2 * RowStage::ROWS + 5;
        for i in 0..rows {
            let t = i as f64 * 1e-3;
            let row = [t, -(i as f64), 0.5 * i as f64];
            direct.push_row(t, &row);
            stage.push(t, &row, &mut staged);
            // Full blocks move on their own, the rest waits for the flush.
            assert_eq!(staged.len(), (i + 1) / RowStage::ROWS * RowStage::ROWS);
        }
        stage.flush(&mut staged);
        assert_eq!(staged, direct);
        assert_eq!(staged.shape_error(), None);
        // An empty stage flushes nothing.
        stage.flush(&mut staged);
        assert_eq!(staged.len(), rows);
    }

    /// A recording without columns still gets its times.
    #[test]
    fn staged_rows_without_columns_keep_their_times() {
        let mut r = Recording::new(Vec::new());
        let mut stage = RowStage::new(0);
        for i in 0..3 {
            stage.push(f64::from(i), &[], &mut r);
        }
        stage.flush(&mut r);
        assert_eq!(r.time, [0.0, 1.0, 2.0]);
    }

    #[test]
    fn cleared_stage_drops_its_rows() {
        let mut r = Recording::new(names());
        let mut stage = RowStage::new(2);
        stage.push(0.0, &[1.0, 2.0], &mut r);
        stage.clear();
        stage.flush(&mut r);
        assert!(r.is_empty());
    }

    #[test]
    #[should_panic(expected = "1 values for 2 columns")]
    fn stage_rejects_wrong_width() {
        RowStage::new(2).push(0.0, &[1.0], &mut Recording::new(names()));
    }
}
