//! The depth-peeling family's options (`--layers`, `--buckets`): the values a frame carries for
//! it (`frame.family::<PeelingOptions>()`), their defaults and ranges. Their flags' specs
//! (`OPTIONS`) and names (`MethodOption`s, which descriptors list in `reads`) are here too.

use crate::error::{Error, Result};
use crate::frame::FamilyOption;
use crate::keyword::keyword_enum;
use crate::methods::options::{flag, parse, parse_optional, MethodOption, OptionSpec, ValueKind};

/// Peeling never records more layers than this in one frame.
pub const MAX_LAYERS: u32 = 1024;

keyword_enum! {
    /// How `bucket` splits each pixel's depth range into buckets (`--buckets`).
    #[derive(Default)]
    pub enum BucketSplit ("--buckets") {
        /// k/2 equal parts of the depth range (Liu et al. 2009's bucket depth peeling).
        #[default]
        Uniform = "uniform",
        /// The paper's adaptive variant: a histogram pass marks which of 1024 equal parts hold
        /// fragments, and the buckets are shared among the occupied parts only.
        Adaptive = "adaptive",
    }
}

/// The depth-peeling family's parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PeelingOptions {
    /// A fixed number of layers per frame; by default the last frame's depth complexity.
    pub layers: Option<u32>,
    /// bucket: how each pixel's depth range splits into buckets.
    pub buckets: BucketSplit,
}

impl FamilyOption for PeelingOptions {
    fn validate(&self) -> Result<()> {
        match self.layers {
            Some(l) if l == 0 || l > MAX_LAYERS => Err(Error::input(format!(
                "--layers {l} is outside 1..{MAX_LAYERS}"
            ))),
            _ => Ok(()),
        }
    }
}

/// `--layers`.
pub const LAYERS: MethodOption = MethodOption::named("layers");
/// `--buckets`.
pub const BUCKETS: MethodOption = MethodOption::named("buckets");

/// The peeling family's options.
pub const OPTIONS: &[OptionSpec] = &[
    OptionSpec {
        option: LAYERS,
        flags: &[flag(
            "layers",
            "--layers",
            "depth peeling: peel this many layers (default: the scene's depth complexity, measured by the frame itself)",
            ValueKind::Optional {
                min: 1,
                max: crate::methods::peeling::MAX_LAYERS,
                start: 8,
            },
            |f| f.family::<PeelingOptions>().layers.map(|n| n.to_string()),
            |f, v| {
 f.family_mut::<PeelingOptions>().layers = parse_optional("--layers", v)?;
 Ok(())
 },
        )],
    },
    OptionSpec {
        option: BUCKETS,
        flags: &[flag(
            "buckets",
            "--buckets",
            "bucket: split each pixel's depth range into k/2 equal buckets (uniform, the paper's method) or share the buckets among the occupied parts of a 1024-part histogram (adaptive, one more geometry pass)",
            ValueKind::Choice(BucketSplit::NAMES),
            |f| Some(f.family::<PeelingOptions>().buckets.name().to_string()),
            |f, v| {
 f.family_mut::<PeelingOptions>().buckets = parse::<BucketSplit>("--buckets", v)?;
 Ok(())
 },
        )],
    },
];
