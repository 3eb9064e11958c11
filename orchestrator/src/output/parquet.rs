//! Parquet export of recordings: one row group, a required DOUBLE column `time` and one per
//! recorded variable, named as in the CSV header. pandas (`read_parquet`), polars
//! (`read_parquet`) and MATLAB (`parquetread`) read it without custom code, and the values
//! are the recorded `f64` bits, so no formatting or parsing is involved at all.
//!
//! Written uncompressed and without dictionary encoding: the samples of a trial are nearly
//! all distinct doubles, which neither shrinks much, and the point of the format is speed.

use std::borrow::Cow;
use std::io::{self, Write};
use std::sync::Arc;

use parquet::basic::{Compression, Repetition, Type as PhysicalType};
use parquet::data_type::DoubleType;
use parquet::errors::ParquetError;
use parquet::file::properties::{EnabledStatistics, WriterProperties};
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::Type;

use super::{Exporter, RecordedRows, Recording};

/// Apache Parquet, `time` then the recorded columns.
#[derive(Debug, Clone, Copy, Default)]
pub struct ParquetExporter;

impl Exporter for ParquetExporter {
    fn extension(&self) -> &'static str {
        "parquet"
    }

    fn write(&self, rec: &Recording, w: &mut dyn Write) -> io::Result<()> {
        if let Some(message) = rec.shape_error() {
            return Err(io::Error::new(io::ErrorKind::InvalidData, message));
        }
        let columns = rec.columns.iter().map(|c| Cow::Borrowed(c.as_slice()));
        write_all(to_parquet(&rec.names, &rec.time, columns), w)
    }

    /// A few columns at a time out of the rows, so that the writer never holds the trial
    /// twice and reads the rows a few times only.
    fn write_rows(&self, rows: &RecordedRows, w: &mut dyn Write) -> io::Result<()> {
        let width = rows.names().len();
        let columns = (0..width).step_by(GROUP).flat_map(|first| {
            let group = rows.columns(first..(first + GROUP).min(width));
            group.into_iter().map(Cow::Owned)
        });
        write_all(to_parquet(rows.names(), rows.time(), columns), w)
    }
}

/// Columns taken out of a master's rows in one pass: eight columns of a 15 s trial at 1 ms
/// are under 1 MB.
const GROUP: usize = 8;

fn write_all(bytes: Result<Vec<u8>, ParquetError>, w: &mut dyn Write) -> io::Result<()> {
    // The writer needs an owned `Send` sink; the file is a few MB per trial.
    let bytes = bytes.map_err(|e| match e {
        ParquetError::External(inner) => io::Error::other(inner),
        other => io::Error::other(other.to_string()),
    })?;
    // In pieces, so that the file's early syncs (`write_atomic`) start before its end.
    for piece in bytes.chunks(1 << 20) {
        w.write_all(piece)?;
    }
    w.flush()
}

/// The file of `time` and `columns`, named `names`.
fn to_parquet<'a>(
    names: &[String],
    time: &'a [f64],
    columns: impl Iterator<Item = Cow<'a, [f64]>>,
) -> Result<Vec<u8>, ParquetError> {
    let field = |name: &str| {
        Type::primitive_type_builder(name, PhysicalType::DOUBLE)
            .with_repetition(Repetition::REQUIRED)
            .build()
            .map(Arc::new)
    };
    let fields = std::iter::once("time")
        .chain(names.iter().map(String::as_str))
        .map(field)
        .collect::<Result<Vec<_>, _>>()?;
    let schema = Arc::new(
        Type::group_type_builder("recording")
            .with_fields(fields)
            .build()?,
    );
    let props = Arc::new(
        WriterProperties::builder()
            .set_compression(Compression::UNCOMPRESSED)
            .set_dictionary_enabled(false)
            .set_statistics_enabled(EnabledStatistics::Chunk)
            .build(),
    );
    let mut writer = SerializedFileWriter::new(Vec::new(), schema, props)?;
    let mut group = writer.next_row_group()?;
    let mut data = std::iter::once(Cow::Borrowed(time)).chain(columns);
    while let Some(mut col) = group.next_column()? {
        let values = data
            .next()
            .ok_or_else(|| ParquetError::General("more columns than data".into()))?;
        col.typed::<DoubleType>().write_batch(&values, None, None)?;
        col.close()?;
    }
    group.close()?;
    writer.into_inner()
}

#[cfg(test)]
mod tests {
    use super::*;
    use parquet::file::reader::{FileReader, SerializedFileReader};
    use parquet::record::Field;

    /// The file holds the schema's names in order and every value's exact bits, NaN and
    /// signed zero included, read back by the crate's own row reader.
    #[test]
    fn round_trip_is_bit_exact() {
        let names = vec!["plant.pose[1]".to_owned(), "a, \"quoted\"".to_owned()];
        let mut rec = Recording::with_capacity(names.clone(), 4);
        let awkward = [-0.0, f64::NAN, 1e-300, f64::MAX];
        for (i, &v) in awkward.iter().enumerate() {
            rec.push_row(i as f64 * 1e-3, &[v, -v]);
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("trial.parquet");
        super::super::write_recording(&path, &rec, &ParquetExporter).unwrap();
        let reader = SerializedFileReader::new(std::fs::File::open(&path).unwrap()).unwrap();
        let schema = reader.metadata().file_metadata().schema_descr();
        let got: Vec<&str> = schema.columns().iter().map(|c| c.name()).collect();
        assert_eq!(got, ["time", "plant.pose[1]", "a, \"quoted\""]);
        let rows: Vec<Vec<u64>> = reader
            .get_row_iter(None)
            .unwrap()
            .map(|row| {
                row.unwrap()
                    .get_column_iter()
                    .map(|(_, f)| match f {
                        Field::Double(x) => x.to_bits(),
                        other => panic!("{other:?}"),
                    })
                    .collect()
            })
            .collect();
        assert_eq!(rows.len(), awkward.len());
        for (i, row) in rows.iter().enumerate() {
            let want = [rec.time[i], rec.columns[0][i], rec.columns[1][i]];
            let want: Vec<u64> = want.iter().map(|x| x.to_bits()).collect();
            assert_eq!(row, &want, "row {i}");
        }
    }

    /// A master's rows, written a few columns at a time out of the rows, make the same file
    /// as the same signals as columns; with no columns too.
    #[test]
    fn rows_write_the_bytes_of_their_columns() {
        // Two groups of columns and a partial one.
        let names: Vec<String> = (0..2 * GROUP + 3).map(|c| format!("c{c}")).collect();
        let mut wide = RecordedRows::with_capacity(names, 0);
        for i in 0..1000 {
            let x = f64::from(i);
            let row: Vec<f64> = (0..2 * GROUP + 3).map(|c| (x + c as f64).sin()).collect();
            wide.push(x * 1e-3, &row);
        }
        let mut empty = RecordedRows::with_capacity(Vec::new(), 0);
        empty.push(0.0, &[]);
        for rows in [&wide, &empty] {
            let (mut ours, mut theirs) = (Vec::new(), Vec::new());
            ParquetExporter.write_rows(rows, &mut ours).unwrap();
            ParquetExporter
                .write(&rows.to_recording(), &mut theirs)
                .unwrap();
            assert!(!ours.is_empty());
            assert!(ours == theirs, "{} columns", rows.names().len());
        }
    }

    #[test]
    fn inconsistent_recording_is_invalid_data() {
        let mut rec = Recording::new(vec!["a".into()]);
        rec.push_row(0.0, &[1.0]);
        rec.time.push(1.0);
        let err = ParquetExporter.write(&rec, &mut Vec::new()).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::InvalidData);
        assert_eq!(ParquetExporter.extension(), "parquet");
    }
}
