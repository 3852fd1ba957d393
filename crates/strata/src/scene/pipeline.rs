//! How a scene's opaque surfaces are lit: a scene file may ask for a pipeline (`crate::deferred`
//! draws it).

#[cfg(feature = "serde")]
use serde::Serialize;

/// How opaque surfaces are lit (`--pipeline`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(Serialize, serde::Deserialize))]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum Pipeline {
    /// One depth-tested pass shading every fragment with every light.
    Forward,
    /// G-buffer, light volumes, composite (seed 004).
    Deferred,
}
