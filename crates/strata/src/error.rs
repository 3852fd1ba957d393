//! The library's error type. Every error is one line naming what is wrong; the CLI maps
//! [`Error::Input`] and [`Error::Unsupported`] to exit status 2.

use thiserror::Error;

/// strata's result type.
pub type Result<T> = std::result::Result<T, Error>;

/// What went wrong, in one line.
#[derive(Debug, Error)]
pub enum Error {
    /// Bad input: a missing or malformed file, a bad option value, an impossible budget.
    #[error("{0}")]
    Input(String),
    /// The GPU lacks what the request needs (adapter, feature, limit).
    #[error("{0}")]
    Unsupported(String),
    /// Something failed on the GPU or in I/O while rendering.
    #[error("{0}")]
    Runtime(String),
    /// The device is lost (destroyed, reset by the driver, removed): nothing can be recorded on
    /// it again. Open a new device and make new recorders on it.
    #[error("{0}")]
    DeviceLost(String),
}

/// The phrase every error about a buffer over the device's largest storage binding contains
/// (a smaller picture, band or k needs less): [`crate::Renderer`] then renders in bands.
pub const OVER_BINDING: &str = "more than the device binds";

/// A piece of the input as an error message quotes it: at most 60 characters, cut with "…", its
/// control characters escaped (`\n`, `\u{1b}`), so a long or binary value can neither flood
/// the one line nor break it.
pub fn quoted(input: &str) -> String {
    const MAX: usize = 60;
    let mut out = String::with_capacity(input.len().min(4 * MAX));
    for (i, c) in input.chars().enumerate() {
        if i == MAX {
            out.push('…');
            break;
        }
        match c.is_control() {
            true => out.extend(c.escape_default()),
            false => out.push(c),
        }
    }
    out
}

impl Error {
    /// A [`Error::Input`] error.
    pub fn input(msg: impl Into<String>) -> Self {
        Error::Input(msg.into())
    }
    /// A [`Error::Unsupported`] error.
    pub fn unsupported(msg: impl Into<String>) -> Self {
        Error::Unsupported(msg.into())
    }
    /// A [`Error::Runtime`] error.
    pub fn runtime(msg: impl Into<String>) -> Self {
        Error::Runtime(msg.into())
    }
}
