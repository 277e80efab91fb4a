//! A replay as a video (`vlf replay --video OUT.mp4`): H.264 in MP4 by the `ffmpeg` program, fed
//! raw RGB frames over a pipe. It writes under a hidden temporary name beside `OUT` and renames
//! that to `OUT` once ffmpeg has finished cleanly, so a failure (ffmpeg missing or refusing, a
//! frame that cannot be drawn) leaves no half-written video.

use crate::error::{Result, VlfError};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};

/// How to get ffmpeg where it is missing.
const INSTALL: &str = "install ffmpeg (Debian/Ubuntu: `apt-get install ffmpeg`, or `bash tools/setup.sh test`; macOS: `brew install ffmpeg`) and put it on PATH";

/// An ffmpeg process taking frames of one size.
pub struct VideoWriter {
    child: Child,
    stdin: Option<ChildStdin>,
    /// the hidden file ffmpeg writes (removed when dropped unless renamed to `out`)
    partial: Option<tempfile::TempPath>,
    /// ffmpeg's messages (a file: a pipe left unread could stall it)
    messages: tempfile::NamedTempFile,
    out: PathBuf,
    size: [u32; 2],
    frames: u64,
}

impl VideoWriter {
    /// Start ffmpeg for frames of `size` pixels at `fps` frames per second into `out`. An odd
    /// width or height is padded by one black pixel (H.264's 4:2:0 needs even ones).
    pub fn start(out: &Path, size: [u32; 2], fps: f64) -> Result<VideoWriter> {
        let failed = |message: String| VlfError::Image {
            path: out.to_path_buf(),
            message,
        };
        if !(fps.is_finite() && fps > 0.0) {
            return Err(failed(format!(
                "{fps} frames per second: give a positive rate"
            )));
        }
        let dir = match out.parent().filter(|d| !d.as_os_str().is_empty()) {
            Some(d) => d.to_path_buf(),
            None => PathBuf::from("."),
        };
        std::fs::create_dir_all(&dir).map_err(|e| VlfError::io(&dir, e))?;
        let name = out
            .file_name()
            .map_or("video".into(), |n| n.to_string_lossy());
        let partial = tempfile::Builder::new()
            .prefix(&format!(".{name}."))
            .suffix(".partial")
            .tempfile_in(&dir)
            .map_err(|e| VlfError::io(&dir, e))?
            .into_temp_path();
        let messages = tempfile::NamedTempFile::new().map_err(|e| VlfError::io(&dir, e))?;
        let stderr = messages
            .reopen()
            .map_err(|e| VlfError::io(messages.path(), e))?;
        let [w, h] = size;
        let child = Command::new("ffmpeg")
            .args(["-hide_banner", "-loglevel", "error", "-nostdin", "-y"])
            .args([
                "-f",
                "rawvideo",
                "-pix_fmt",
                "rgb24",
                "-s",
                &format!("{w}x{h}"),
            ])
            .args(["-framerate", &fps.to_string(), "-i", "-", "-an"])
            .args(["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"])
            .args(["-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "18"])
            .args(["-f", "mp4"])
            .arg(&partial)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(stderr)
            .spawn()
            .map_err(|e| match e.kind() {
                std::io::ErrorKind::NotFound => {
                    failed(format!("no ffmpeg program found for the video: {INSTALL}"))
                }
                _ => failed(format!("ffmpeg did not start: {e}")),
            })?;
        let mut writer = VideoWriter {
            child,
            stdin: None,
            partial: Some(partial),
            messages,
            out: out.to_path_buf(),
            size,
            frames: 0,
        };
        writer.stdin = writer.child.stdin.take();
        Ok(writer)
    }

    /// One frame, `size` pixels of RGB.
    pub fn push(&mut self, image: &image::RgbImage) -> Result<()> {
        if image.dimensions() != (self.size[0], self.size[1]) {
            return Err(self.failed(format!(
                "a {}x{} frame for a {}x{} video",
                image.width(),
                image.height(),
                self.size[0],
                self.size[1]
            )));
        }
        let stdin = self.stdin.as_mut().expect("open until finish");
        if let Err(e) = stdin.write_all(image.as_raw()) {
            return Err(self.failed(format!("ffmpeg stopped taking frames ({e})")));
        }
        self.frames += 1;
        Ok(())
    }

    /// Close the pipe, wait for ffmpeg and rename the video into place; the frames written.
    pub fn finish(mut self) -> Result<u64> {
        drop(self.stdin.take());
        let status = match self.child.wait() {
            Ok(status) => status,
            Err(e) => return Err(self.failed(format!("waiting for ffmpeg: {e}"))),
        };
        if !status.success() {
            return Err(self.failed(format!("ffmpeg failed ({status})")));
        }
        let partial = self.partial.take().expect("kept until finished");
        let out = self.out.clone();
        partial
            .persist(&out)
            .map_err(|e| VlfError::io(&out, e.error))?;
        Ok(self.frames)
    }

    /// An error naming the video, with what ffmpeg said.
    fn failed(&self, message: String) -> VlfError {
        let said = std::fs::read_to_string(self.messages.path()).unwrap_or_default();
        let said = said.trim();
        VlfError::Image {
            path: self.out.clone(),
            message: match said.is_empty() {
                true => message,
                false => format!("{message}: {said}"),
            },
        }
    }
}

impl Drop for VideoWriter {
    fn drop(&mut self) {
        // not finished: end ffmpeg; the partial file goes with `partial`
        if self.stdin.take().is_some() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}
