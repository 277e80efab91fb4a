//! The library's one error type. Every message names the file or field at fault and says what
//! to do about it; `anyhow` is used only in the binary (`main.rs`, `cli/`).

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum VlfError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },

    #[error("{path}: cannot write: {source}")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },

    #[error("{path}: {message}")]
    SceneToml { path: PathBuf, message: String },

    #[error("{path}: {message}")]
    Mesh { path: PathBuf, message: String },

    #[error("{path}: material {material:?}: {message}")]
    Material {
        path: PathBuf,
        material: String,
        message: String,
    },

    #[error("{path}: {message}")]
    Config { path: PathBuf, message: String },

    #[error("invalid parameter {name}: {message}")]
    Parameter { name: &'static str, message: String },

    #[error("{path}: not a usable .vlf light field: {message}")]
    LightFieldFile { path: PathBuf, message: String },

    #[error(
        "no GPU adapter found ({detail}). Install a Vulkan driver (on Debian/Ubuntu: \
         `sudo apt-get install mesa-vulkan-drivers` gives the software adapter lavapipe), \
         or run on a machine with a GPU; WGPU_BACKEND=gl tries Mesa's OpenGL instead"
    )]
    NoAdapter { detail: String },

    #[error("cannot open the GPU asked for: {0}")]
    GpuChoice(String),

    #[error("GPU device request failed: {0}")]
    Device(String),

    #[error("GPU resources: {0}")]
    GpuBudget(String),

    #[error("GPU error: {0}")]
    Gpu(String),

    #[error("{path}: cannot write image: {message}")]
    Image { path: PathBuf, message: String },

    #[error("display: {0}")]
    Display(String),

    /// a CAVE cluster under MPI: a lost rank, a refused launch (`cluster/`)
    #[error("cluster: {0}")]
    Cluster(String),

    #[error("export to {target}: {message}")]
    Export {
        target: &'static str,
        message: String,
    },

    #[error("camera {name:?} not found; the scene has: {available}")]
    UnknownCamera { name: String, available: String },
}

pub type Result<T> = std::result::Result<T, VlfError>;

impl VlfError {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        VlfError::Io {
            path: path.into(),
            source,
        }
    }

    /// A file that could not be written (or put in place).
    pub fn write(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        VlfError::Write {
            path: path.into(),
            source,
        }
    }
}

/// Names as an error message lists what there is instead: "a, b, c", or "none".
pub fn names_or_none<S: AsRef<str>>(names: &[S]) -> String {
    match names.is_empty() {
        true => "none".into(),
        false => (names.iter().map(AsRef::as_ref))
            .collect::<Vec<&str>>()
            .join(", "),
    }
}
