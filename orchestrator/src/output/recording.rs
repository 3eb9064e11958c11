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
}
