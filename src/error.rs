//! The one error type of gregvox. Vulkan failures carry the name of the call that failed; input errors
//! name the input (a file, a flag) and the problem, so the CLI can print one line and exit non-zero.
use ash::vk;
use std::path::PathBuf;

/// Everything that can go wrong in gregvox.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A Vulkan call returned an error code.
    #[error("Vulkan call {call} failed: {result}")]
    Vulkan {
        call: &'static str,
        result: vk::Result,
    },
    /// The Vulkan loader or a driver could not be found or opened.
    #[error("{0}")]
    NoDriver(String),
    /// No physical device fits the requirements.
    #[error("no suitable Vulkan device: {0}")]
    NoDevice(String),
    /// A GPU memory allocation failed (out of device memory, or over the configured budget).
    #[error("GPU memory allocation of {bytes} bytes for '{name}' failed: {reason}")]
    Alloc {
        name: String,
        bytes: u64,
        reason: String,
    },
    /// A request goes past what the device can do.
    #[error("{what} exceeds the device limit: {detail}")]
    Limit { what: String, detail: String },
    /// A computation needs more memory than the caller's budget gives it (`VoxelizeOptions::gwn_budget`).
    #[error("{what}: over {detail}")]
    Budget { what: String, detail: String },
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// An input file is malformed.
    #[error("{}: {msg}", path.display())]
    Parse { path: PathBuf, msg: String },
    /// An argument or value is not acceptable.
    #[error("{0}")]
    Invalid(String),
    /// A voxelization went past the caller's time limit (`VoxelizeOptions::deadline`), found at a checkpoint
    /// between its stages.
    #[error("past the time limit of {seconds} s ({stage})")]
    Timeout { seconds: f64, stage: String },
    /// A mesh given in memory cannot be used (no usable triangle, no vertices…). Callers that loaded it from
    /// a file prefix the file's name ([`Error::for_input`]).
    #[error("{0}")]
    Mesh(String),
}

/// gregvox's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
    /// Names the input a [`Error::Mesh`] came from (other errors are returned unchanged).
    pub fn for_input(self, input: &std::path::Path) -> Self {
        match self {
            Error::Mesh(msg) => Error::parse(input, msg),
            e => e,
        }
    }

    /// A malformed input file.
    pub fn parse(path: impl Into<PathBuf>, msg: impl Into<String>) -> Self {
        Error::Parse {
            path: path.into(),
            msg: msg.into(),
        }
    }
}

/// Attaches the name of the failing Vulkan call to a `vk::Result`.
pub trait VkContext<T> {
    /// Maps the error to [`Error::Vulkan`] naming `call`.
    fn vk(self, call: &'static str) -> Result<T>;
}

impl<T> VkContext<T> for std::result::Result<T, vk::Result> {
    fn vk(self, call: &'static str) -> Result<T> {
        self.map_err(|result| Error::Vulkan { call, result })
    }
}
