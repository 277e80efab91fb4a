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
use arrow_array::{
    ArrayRef, Float32Array, Float64Array, RecordBatch, StringArray, UInt32Array, UInt64Array,
};
use arrow_schema::{DataType, Field, Schema};
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
        let batch = batch(&self.rows, &self.names, self.targets)?;
        let name = format!("part-{:06}.parquet", self.parts);
        let (hidden, part) = (self.dir.join(format!(".{name}")), self.dir.join(&name));
        let file = std::fs::File::create(&hidden).map_err(|e| VlfError::io(&hidden, e))?;
        let written = |e: parquet::errors::ParquetError| {
            VlfError::io(&hidden, std::io::Error::other(e.to_string()))
        };
        let mut writer =
            parquet::arrow::ArrowWriter::try_new(file, batch.schema(), None).map_err(written)?;
        writer.write(&batch).map_err(written)?;
        let file = writer.into_inner().map_err(written)?;
        file.sync_all().map_err(|e| VlfError::io(&hidden, e))?;
        std::fs::rename(&hidden, &part).map_err(|e| VlfError::io(&part, e))?;
        self.rows.clear();
        self.parts += 1;
        Ok(())
    }
}

fn f32s(rows: &[FrameRecord], f: impl Fn(&FrameRecord) -> f32) -> ArrayRef {
    Arc::new(Float32Array::from_iter_values(rows.iter().map(f)))
}

fn u32s(rows: &[FrameRecord], f: impl Fn(&FrameRecord) -> u32) -> ArrayRef {
    Arc::new(UInt32Array::from_iter_values(rows.iter().map(f)))
}

fn opt_f64s(rows: &[FrameRecord], f: impl Fn(&FrameRecord) -> Option<f64>) -> ArrayRef {
    Arc::new(Float64Array::from(rows.iter().map(f).collect::<Vec<_>>()))
}

/// A wand's or hand's eight columns: 1 where given, then its position and rotation (the CSV's
/// zeros where not).
fn held_columns(
    rows: &[FrameRecord],
    held: impl Fn(&FrameRecord) -> Option<&WandPose>,
) -> Vec<ArrayRef> {
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

/// `rows` as one batch, its columns in frames.csv's order (`names`, with `targets` tracked
/// targets), typed: counts as u32 (the frame u64), positions, rotations and shares as f32, times
/// as f64 (null where the CSV is empty), `drawn`, `condition`, `objects_hidden`, `flash` and
/// `events` as text.
fn batch(rows: &[FrameRecord], names: &[String], targets: usize) -> Result<RecordBatch> {
    let mut columns: Vec<ArrayRef> = vec![
        Arc::new(UInt64Array::from_iter_values(rows.iter().map(|r| r.frame))),
        Arc::new(Float64Array::from_iter_values(
            rows.iter().map(|r| r.time_s),
        )),
        Arc::new(StringArray::from_iter_values(
            rows.iter().map(|r| r.drawn.name()),
        )),
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
    columns.push(Arc::new(StringArray::from_iter_values(
        rows.iter().map(|r| r.condition.as_str()),
    )));
    columns.push(opt_f64s(rows, |r| r.object_time_s));
    columns.extend(held_columns(rows, |r| r.raw.head.as_ref()));
    columns.extend(held_columns(rows, |r| r.raw.wand.as_ref()));
    columns.extend(held_columns(rows, |r| r.raw.left_hand.as_ref()));
    // as the CSV: a record without switches (from an older log) as every object on
    let switches = |r: &FrameRecord| r.objects.clone().unwrap_or_else(ObjectSwitches::all_on);
    let separator = HIDDEN_SEPARATOR.to_string();
    columns.push(Arc::new(StringArray::from_iter_values(
        rows.iter().map(|r| switches(r).hidden.join(&separator)),
    )));
    columns.push(u32s(rows, |r| switches(r).shadows as u32));
    columns.push(u32s(rows, |r| switches(r).reflections as u32));
    columns.push(Arc::new(StringArray::from_iter_values(
        rows.iter().map(|r| flash_name(r.flash)),
    )));
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
    columns.push(Arc::new(StringArray::from_iter_values(
        rows.iter().map(|r| r.events.as_str()),
    )));
    if columns.len() != names.len() {
        return Err(VlfError::Display(format!(
            "frames.parquet: {} columns for a header of {}",
            columns.len(),
            names.len()
        )));
    }
    let fields: Vec<Field> = (names.iter().zip(&columns))
        .map(|(n, c)| {
            Field::new(
                n,
                c.data_type().clone(),
                *c.data_type() == DataType::Float64,
            )
        })
        .collect();
    RecordBatch::try_new(Arc::new(Schema::new(fields)), columns)
        .map_err(|e| VlfError::Display(format!("frames.parquet: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::log::{Drawn, FrameRecord};
    use crate::tracking::pose::Pose;

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
        let part = std::fs::File::open(dir.path().join(PARQUET_DIR).join(&files[0])).unwrap();
        let reader = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(part)
            .unwrap()
            .build()
            .unwrap();
        let batches: Vec<RecordBatch> = reader.map(|b| b.unwrap()).collect();
        let batch = &batches[0];
        assert_eq!(batch.num_rows(), 2);
        assert_eq!(batch.num_columns(), names().len());
        let gpu = batch.column_by_name("gpu_ms").unwrap();
        assert!(gpu.is_null(0) && !gpu.is_null(1));
        let events = batch.column_by_name("events").unwrap();
        let events = events.as_any().downcast_ref::<StringArray>().unwrap();
        assert_eq!(events.value(1), "a \"quoted\" event");
        let condition = batch.column_by_name("condition").unwrap();
        let condition = condition.as_any().downcast_ref::<StringArray>().unwrap();
        assert_eq!(condition.value(0), "gi-off");
        let text = |name: &str| {
            let column = batch.column_by_name(name).unwrap();
            let column = column.as_any().downcast_ref::<StringArray>().unwrap();
            column.value(0).to_string()
        };
        assert_eq!(text("objects_hidden"), "cube|body");
        assert_eq!(text("flash"), "white");
        let shadows = batch.column_by_name("shadows").unwrap();
        let shadows = shadows.as_any().downcast_ref::<UInt32Array>().unwrap();
        assert_eq!(shadows.value(0), 0);
    }
}
