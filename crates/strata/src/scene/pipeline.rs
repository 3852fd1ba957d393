//! How a scene's opaque surfaces are lit: a scene file may ask for a pipeline (`crate::deferred`
//! draws it).

use crate::keyword::keyword_enum;

keyword_enum! {
    /// How opaque surfaces are lit (`--pipeline`).
    #[cfg_attr(feature = "serde", derive(serde::Deserialize))]
    pub enum Pipeline ("--pipeline") {
        /// One depth-tested pass shading every fragment with every light.
        Forward = "forward",
        /// G-buffer, light volumes, composite (seed 004).
        Deferred = "deferred",
    }
}
