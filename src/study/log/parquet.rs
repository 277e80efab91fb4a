//! The session log's frames as Parquet (`DIR/frames.parquet/`), beside `frames.csv`, with the
//! same columns and names, typed: a folder of parts, `part-000000.parquet`, ..., one for each
//! second of rows (written when the CSV is flushed), which pyarrow, pandas, polars and DuckDB
//! read as one table (`pyarrow.parquet.read_table("DIR/frames.parquet")`).
//!
//! Why parts: a Parquet file is readable only once its footer is written, at its close. One
//! file for the session, its row groups written every second, would be lost whole to a SIGKILL
//! or a power cut; a part closed every second loses at most the last second, as the CSV does.
//! Each part is written under a hidden name (`.part-000000.parquet`, which readers skip) and
//! renamed once complete and on the disk, so a part is either whole or absent.

use super::{flash_name, FrameRecord, ObjectSwitches, HIDDEN_SEPARATOR};
use crate::error::{Result, VlfError};
use crate::tracking::pose::WandPose;
use parquet::basic::{LogicalType, Repetition, Type as Physical};
use parquet::data_type::{ByteArray, ByteArrayType, DoubleType, FloatType, Int32Type, Int64Type};
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::Type;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The parts' folder in a session log's folder.
pub const PARQUET_DIR: &str = "frames.parquet";

/// Rows waiting for their part, and the parts written.
pub struct FramesParquet {
    dir: PathBuf,
    names: Vec<String>,
    /// the declared tracked targets: each row has this many
    targets: usize,
    rows: Vec<FrameRecord>,
    parts: usize,
}

impl FramesParquet {
    /// A new parts folder in `log_dir`, for rows of the columns `names` (`log::columns`) with
    /// `targets` tracked targets.
    pub fn create(log_dir: &Path, names: Vec<String>, targets: usize) -> Result<FramesParquet> {
        let dir = log_dir.join(PARQUET_DIR);
        std::fs::create_dir(&dir).map_err(|e| VlfError::io(&dir, e))?;
        Ok(FramesParquet {
            dir,
            names,
            targets,
            rows: Vec::new(),
            parts: 0,
        })
    }

    /// A row, in the next part.
    pub fn push(&mut self, r: &FrameRecord) {
        self.rows.push(r.clone());
    }

    /// The rows since the last part as a new part, closed and on the disk (none without rows).
    pub fn flush(&mut self) -> Result<()> {
        if self.rows.is_empty() {
            return Ok(());
        }
        let columns = columns(&self.rows, self.targets);
        if columns.len() != self.names.len() {
            return Err(VlfError::Display(format!(
                "frames.parquet: {} columns for a header of {}",
                columns.len(),
                self.names.len()
            )));
        }
        let name = format!("part-{:06}.parquet", self.parts);
        let (hidden, part) = (self.dir.join(format!(".{name}")), self.dir.join(&name));
        let file = std::fs::File::create(&hidden).map_err(|e| VlfError::write(&hidden, e))?;
        let written = |e: parquet::errors::ParquetError| {
            VlfError::io(&hidden, std::io::Error::other(e.to_string()))
        };
        let file = write_part(file, &self.names, &columns).map_err(written)?;
        file.sync_all().map_err(|e| VlfError::io(&hidden, e))?;
        std::fs::rename(&hidden, &part).map_err(|e| VlfError::io(&part, e))?;
        self.rows.clear();
        self.parts += 1;
        Ok(())
    }
}

/// One column's values, typed as pyarrow and pandas read them back.
enum Column {
    U64(Vec<u64>),
    U32(Vec<u32>),
    F32(Vec<f32>),
    /// null where the CSV is empty
    F64(Vec<Option<f64>>),
    Text(Vec<String>),
}

impl Column {
    /// The column's Parquet type: unsigned integers as INT32/INT64 with an unsigned logical
    /// type, floats as FLOAT/DOUBLE (DOUBLE nullable), text as UTF-8 byte arrays.
    fn schema(&self, name: &str) -> parquet::errors::Result<Type> {
        let (physical, logical, repetition) = match self {
            Column::U64(_) => (Physical::INT64, Some(unsigned(64)), Repetition::REQUIRED),
            Column::U32(_) => (Physical::INT32, Some(unsigned(32)), Repetition::REQUIRED),
            Column::F32(_) => (Physical::FLOAT, None, Repetition::REQUIRED),
            Column::F64(_) => (Physical::DOUBLE, None, Repetition::OPTIONAL),
            Column::Text(_) => (
                Physical::BYTE_ARRAY,
                Some(LogicalType::String),
                Repetition::REQUIRED,
            ),
        };
        Type::primitive_type_builder(name, physical)
            .with_repetition(repetition)
            .with_logical_type(logical)
            .build()
    }

    /// Writes the values into the row group's next column chunk. Unsigned values are stored
    /// in their signed physical type bit for bit, as the Parquet format says.
    fn write(
        &self,
        column: &mut parquet::file::writer::SerializedColumnWriter<'_>,
    ) -> parquet::errors::Result<()> {
        match self {
            Column::U64(v) => {
                let bits: Vec<i64> = v.iter().map(|&x| x as i64).collect();
                column.typed::<Int64Type>().write_batch(&bits, None, None)?;
            }
            Column::U32(v) => {
                let bits: Vec<i32> = v.iter().map(|&x| x as i32).collect();
                column.typed::<Int32Type>().write_batch(&bits, None, None)?;
            }
            Column::F32(v) => {
                column.typed::<FloatType>().write_batch(v, None, None)?;
            }
            Column::F64(v) => {
                let present: Vec<f64> = v.iter().flatten().copied().collect();
                let defined: Vec<i16> = v.iter().map(|x| x.is_some() as i16).collect();
                column
                    .typed::<DoubleType>()
                    .write_batch(&present, Some(&defined), None)?;
            }
            Column::Text(v) => {
                let bytes: Vec<ByteArray> = v.iter().map(|s| ByteArray::from(s.as_str())).collect();
                column
                    .typed::<ByteArrayType>()
                    .write_batch(&bytes, None, None)?;
            }
        }
        Ok(())
    }
}

fn unsigned(bit_width: i8) -> LogicalType {
    LogicalType::integer(bit_width, false)
}

/// `columns` named `names` as one row group into `file`, footer included; the file back.
fn write_part(
    file: std::fs::File,
    names: &[String],
    columns: &[Column],
) -> parquet::errors::Result<std::fs::File> {
    let fields = (names.iter().zip(columns))
        .map(|(n, c)| c.schema(n).map(Arc::new))
        .collect::<parquet::errors::Result<Vec<_>>>()?;
    let schema = Type::group_type_builder("frames")
        .with_fields(fields)
        .build()?;
    let properties = WriterProperties::builder().build();
    let mut writer = SerializedFileWriter::new(file, Arc::new(schema), Arc::new(properties))?;
    let mut group = writer.next_row_group()?;
    for c in columns {
        let mut column = group.next_column()?.ok_or_else(|| {
            parquet::errors::ParquetError::General("fewer columns than the schema".into())
        })?;
        c.write(&mut column)?;
        column.close()?;
    }
    group.close()?;
    writer.into_inner()
}

fn f32s(rows: &[FrameRecord], f: impl Fn(&FrameRecord) -> f32) -> Column {
    Column::F32(rows.iter().map(f).collect())
}

fn u32s(rows: &[FrameRecord], f: impl Fn(&FrameRecord) -> u32) -> Column {
    Column::U32(rows.iter().map(f).collect())
}

fn opt_f64s(rows: &[FrameRecord], f: impl Fn(&FrameRecord) -> Option<f64>) -> Column {
    Column::F64(rows.iter().map(f).collect())
}

fn texts(rows: &[FrameRecord], f: impl Fn(&FrameRecord) -> String) -> Column {
    Column::Text(rows.iter().map(f).collect())
}

/// A wand's or hand's eight columns: 1 where given, then its position and rotation (the CSV's
/// zeros where not).
fn held_columns(
    rows: &[FrameRecord],
    held: impl Fn(&FrameRecord) -> Option<&WandPose>,
) -> Vec<Column> {
    let parts: [fn(&WandPose) -> f32; 7] = [
        |w| w.position.x,
        |w| w.position.y,
        |w| w.position.z,
        |w| w.rotation.x,
        |w| w.rotation.y,
        |w| w.rotation.z,
        |w| w.rotation.w,
    ];
    let mut columns = vec![u32s(rows, |r| held(r).is_some() as u32)];
    columns.extend(parts.map(|part| f32s(rows, |r| held(r).map_or(0.0, part))));
    columns
}

/// `rows`' columns in frames.csv's order (with `targets` tracked targets), typed: counts as u32
/// (the frame u64), positions, rotations and shares as f32, times as f64 (null where the CSV is
/// empty), `drawn`, `condition`, `objects_hidden`, `flash` and `events` as text.
fn columns(rows: &[FrameRecord], targets: usize) -> Vec<Column> {
    let mut columns = vec![
        Column::U64(rows.iter().map(|r| r.frame).collect()),
        Column::F64(rows.iter().map(|r| Some(r.time_s)).collect()),
        texts(rows, |r| r.drawn.name().to_string()),
    ];
    let pose: [fn(&FrameRecord) -> f32; 11] = [
        |r| r.pose.head.x,
        |r| r.pose.head.y,
        |r| r.pose.head.z,
        |r| r.pose.head_rotation.x,
        |r| r.pose.head_rotation.y,
        |r| r.pose.head_rotation.z,
        |r| r.pose.head_rotation.w,
        |r| r.pose.room_position.x,
        |r| r.pose.room_position.y,
        |r| r.pose.room_position.z,
        |r| r.pose.room_yaw_deg,
    ];
    columns.extend(pose.iter().map(|f| f32s(rows, f)));
    columns.extend(held_columns(rows, |r| r.wand.as_ref()));
    columns.push(opt_f64s(rows, |r| r.gpu_ms));
    columns.push(opt_f64s(rows, |r| r.cpu_ms));
    columns.push(u32s(rows, |r| r.block));
    columns.push(u32s(rows, |r| r.trial));
    columns.push(opt_f64s(rows, |r| r.pose_to_submit_ms));
    columns.push(opt_f64s(rows, |r| r.pose_to_photon_ms));
    columns.extend(held_columns(rows, |r| r.left_hand.as_ref()));
    columns.push(texts(rows, |r| r.condition.clone()));
    columns.push(opt_f64s(rows, |r| r.object_time_s));
    columns.extend(held_columns(rows, |r| r.raw.head.as_ref()));
    columns.extend(held_columns(rows, |r| r.raw.wand.as_ref()));
    columns.extend(held_columns(rows, |r| r.raw.left_hand.as_ref()));
    // as the CSV: a record without switches (from an older log) as every object on
    let switches = |r: &FrameRecord| r.objects.clone().unwrap_or_else(ObjectSwitches::all_on);
    let separator = HIDDEN_SEPARATOR.to_string();
    columns.push(texts(rows, |r| switches(r).hidden.join(&separator)));
    columns.push(u32s(rows, |r| switches(r).shadows as u32));
    columns.push(u32s(rows, |r| switches(r).reflections as u32));
    columns.push(texts(rows, |r| flash_name(r.flash).to_string()));
    let views = rows.first().map_or(0, |r| r.views.len());
    for v in 0..views {
        columns.push(u32s(rows, |r| r.views[v].samples_per_pixel));
        columns.push(u32s(rows, |r| r.views[v].paced_samples));
        columns.push(f32s(rows, |r| r.views[v].paced_fraction));
        columns.push(u32s(rows, |r| r.views[v].mirror_bounces));
        columns.push(u32s(rows, |r| r.views[v].fixed_work));
    }
    // a headset's eyes: position, rotation, field of view
    let eyes = rows.first().map_or(0, |r| r.eyes.len());
    for e in 0..eyes {
        for k in 0..11 {
            columns.push(f32s(rows, |r| {
                let eye = &r.eyes[e];
                match k {
                    0..3 => eye.position[k],
                    3..7 => eye.orientation[k - 3],
                    _ => eye.fov[k - 7],
                }
            }));
        }
    }
    for k in 0..targets {
        columns.extend(held_columns(rows, |r| r.targets[k].as_ref()));
        columns.extend(held_columns(rows, |r| r.raw.targets[k].as_ref()));
    }
    columns.push(texts(rows, |r| r.events.clone()));
    columns
}

/// A part's rows read back by column name (the unit tests of this module and of `log`).
#[cfg(test)]
pub(crate) fn read_part(path: &Path) -> Vec<Vec<(String, parquet::record::Field)>> {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let reader = SerializedFileReader::new(std::fs::File::open(path).unwrap()).unwrap();
    reader
        .get_row_iter(None)
        .unwrap()
        .map(|row| {
            let row = row.unwrap();
            row.get_column_iter()
                .map(|(n, f)| (n.clone(), f.clone()))
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::log::{Drawn, FrameRecord};
    use crate::tracking::pose::Pose;
    use parquet::record::Field;

    fn record(frame: u64) -> FrameRecord {
        FrameRecord {
            frame,
            time_s: frame as f64 * 0.5,
            drawn: Drawn::Timed,
            pose: Pose {
                head: glam::Vec3::new(0.1, 1.7, 0.2),
                head_rotation: glam::Quat::IDENTITY,
                room_position: glam::Vec3::ZERO,
                room_yaw_deg: 15.0,
            },
            wand: None,
            left_hand: None,
            targets: Default::default(),
            gpu_ms: (frame > 0).then_some(1.5),
            cpu_ms: None,
            block: 1,
            trial: 2,
            pose_to_submit_ms: Some(0.25),
            pose_to_photon_ms: Some(8.5),
            object_time_s: Some(0.5),
            raw: Default::default(),
            views: Vec::new(),
            events: "a \"quoted\" event".into(),
            condition: "gi-off".into(),
            objects: Some(ObjectSwitches {
                hidden: vec!["cube".into(), "body".into()],
                shadows: false,
                reflections: true,
            }),
            flash: Some(true),
            eyes: Vec::new(),
        }
    }

    fn names() -> Vec<String> {
        let csv = crate::study::log::columns(&[], false, &[]);
        csv.into_iter().map(|(n, _)| n).collect()
    }

    #[test]
    fn each_flush_closes_a_whole_part_that_reads_back() {
        let dir = tempfile::tempdir().unwrap();
        let mut p = FramesParquet::create(dir.path(), names(), 0).unwrap();
        p.push(&record(0));
        p.push(&record(1));
        p.flush().unwrap();
        p.flush().unwrap(); // no rows: no part
        p.push(&record(2));
        p.flush().unwrap();
        let mut files: Vec<String> = std::fs::read_dir(dir.path().join(PARQUET_DIR))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        files.sort();
        assert_eq!(files, ["part-000000.parquet", "part-000001.parquet"]);
        let rows = read_part(&dir.path().join(PARQUET_DIR).join(&files[0]));
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[0].len(), names().len());
        let column_names: Vec<&str> = rows[0].iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(column_names, names());
        let field =
            |row: usize, name: &str| rows[row].iter().find(|(n, _)| n == name).unwrap().1.clone();
        assert_eq!(field(0, "gpu_ms"), Field::Null);
        assert_eq!(field(1, "gpu_ms"), Field::Double(1.5));
        assert_eq!(field(1, "frame"), Field::ULong(1));
        assert_eq!(field(1, "events"), Field::Str("a \"quoted\" event".into()));
        assert_eq!(field(0, "condition"), Field::Str("gi-off".into()));
        assert_eq!(field(0, "objects_hidden"), Field::Str("cube|body".into()));
        assert_eq!(field(0, "flash"), Field::Str("white".into()));
        assert_eq!(field(0, "shadows"), Field::UInt(0));
        assert_eq!(field(0, "trial"), Field::UInt(2));
        assert_eq!(field(0, "room_yaw_deg"), Field::Float(15.0));
    }
}
