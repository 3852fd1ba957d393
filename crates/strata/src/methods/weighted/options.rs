//! The weighted family's options (`--weight`, `--depth-scale`, `--moments`, `--passes`,
//! `--coefficients`, `--opacity`): the values a frame carries for it (`frame.family::<WeightedOptions>()`),
//! their defaults and ranges. Their flags' specs
//! (`OPTIONS`) and names (`MethodOption`s, which descriptors list in `reads`) are here too.

use std::str::FromStr;

use crate::error::{Error, Result};
use crate::frame::FamilyOption;
use crate::keyword::keyword_enum;
use crate::methods::options::{flag, parse, MethodOption, OptionSpec, ValueKind};

keyword_enum! {
    /// The weight function of weighted blended OIT: McGuire & Bavoil 2013, equations 7–10.
    #[derive(Default)]
    pub enum Weight ("--weight") {
        /// α·clamp(10 / (10⁻⁵ + (|z|/5)² + (|z|/200)⁶), 10⁻², 3·10³).
        #[default]
        Eq7 = "eq7",
        /// α·clamp(10 / (10⁻⁵ + (|z|/10)³ + (|z|/200)⁶), 10⁻², 3·10³).
        Eq8 = "eq8",
        /// α·clamp(0.03 / (10⁻⁵ + (|z|/200)⁴), 10⁻², 3·10³).
        Eq9 = "eq9",
        /// α·max(10⁻², 3·10³·(1 − d)³), d the window depth.
        Eq10 = "eq10",
    }
}

keyword_enum! {
    /// How `wavg` takes a pixel's opacity from its fragments (`--opacity`).
    #[derive(Default)]
    pub enum Opacity ("--opacity") {
        /// From their average opacity ᾱ = Σα/n: 1 − (1 − ᾱ)ⁿ, as if all n fragments were as
        /// opaque (Bavoil & Myers 2008, the weighted average's).
        #[default]
        Average = "average",
        /// Exactly, 1 − Π(1 − α), by multiplicative blending (McGuire & Bavoil 2013's coverage).
        Product = "product",
    }
}

/// mboit's moments: power moments of the warped depth (4, 6 or 8), or trigonometric moments of
/// its angle on the unit circle (2, 3 or 4 complex moments: 4, 6 or 8 real values).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Moments {
    /// E\[zᵏ\] for k = 1..n.
    Power(u32),
    /// E\[e^{ikφ}\] for k = 1..n.
    Trigonometric(u32),
    /// n Haar coefficients of the absorbance step over the warped depth (`wavelet`'s
    /// `--coefficients`, not an mboit `--moments`).
    Haar(u32),
}

impl Moments {
    /// Every count mboit builds, in the order a menu lists them.
    pub const ALL: [Moments; 6] = [
        Moments::Power(4),
        Moments::Power(6),
        Moments::Power(8),
        Moments::Trigonometric(2),
        Moments::Trigonometric(3),
        Moments::Trigonometric(4),
    ];

    /// The real values it stores per sample besides b0.
    pub fn reals(self) -> u32 {
        match self {
            Moments::Power(n) | Moments::Haar(n) => n,
            Moments::Trigonometric(n) => 2 * n,
        }
    }

    /// Whether it is one of the counts mboit builds.
    pub fn supported(self) -> bool {
        Moments::ALL.contains(&self)
    }
}

impl Default for Moments {
    fn default() -> Self {
        Moments::Power(4)
    }
}

impl std::fmt::Display for Moments {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Moments::Power(n) => write!(f, "{n}"),
            Moments::Trigonometric(n) => write!(f, "trig{n}"),
            Moments::Haar(n) => write!(f, "haar{n}"),
        }
    }
}

impl FromStr for Moments {
    type Err = Error;

    fn from_str(s: &str) -> Result<Moments> {
        let parsed = match s.strip_prefix("trig") {
            Some(n) => n.parse().ok().map(Moments::Trigonometric),
            None => s.parse().ok().map(Moments::Power),
        };
        parsed.filter(|m| m.supported()).ok_or_else(|| {
            Error::input(format!(
                "--moments '{}' is not 4, 6, 8 (power moments) or trig2, trig3, trig4 (trigonometric)",
                crate::error::quoted(s)
            ))
        })
    }
}

/// The most passes `stochastic` takes (`--passes`).
pub const MAX_STOCHASTIC_PASSES: u32 = 64;

/// The coefficient counts `wavelet` builds: the scaling coefficient and the Haar wavelets of 2
/// or 3 levels.
pub const WAVELET_COEFFICIENTS: [u32; 2] = [4, 8];

/// The weighted family's parameters (wboit, mboit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightedOptions {
    /// wboit: the weight function.
    pub weight: Weight,
    /// wboit: view-space distances are multiplied by this before the weight function, whose
    /// constants assume distances of 0.1 to 500 units.
    pub depth_scale: f64,
    /// mboit: power moments 4 (default), 6 or 8, or trigonometric moments 2, 3 or 4.
    pub moments: Moments,
    /// stochastic: passes of S samples each (1 by default).
    pub passes: u32,
    /// wavelet: Haar coefficients per sample, 4 or 8 (8 by default).
    pub coefficients: u32,
    /// wavg: how a pixel's opacity comes from its fragments' (the paper's average by default).
    pub opacity: Opacity,
}

impl Default for WeightedOptions {
    fn default() -> Self {
        WeightedOptions {
            weight: Weight::Eq7,
            depth_scale: 1.0,
            moments: Moments::Power(4),
            passes: 1,
            coefficients: 8,
            opacity: Opacity::Average,
        }
    }
}

impl FamilyOption for WeightedOptions {
    fn validate(&self) -> Result<()> {
        if !(self.depth_scale.is_finite() && self.depth_scale > 0.0) {
            return Err(Error::input(format!(
                "--depth-scale {} must be a positive number",
                self.depth_scale
            )));
        }
        if !self.moments.supported() {
            return Err(Error::input(format!(
                "--moments {} is not 4, 6, 8, trig2, trig3 or trig4 (mboit's moments)",
                self.moments
            )));
        }
        if !WAVELET_COEFFICIENTS.contains(&self.coefficients) {
            return Err(Error::input(format!(
                "--coefficients {} is not 4 or 8 (wavelet's Haar coefficients)",
                self.coefficients
            )));
        }
        if !(1..=MAX_STOCHASTIC_PASSES).contains(&self.passes) {
            return Err(Error::input(format!(
                "--passes {} is outside 1..{MAX_STOCHASTIC_PASSES} (stochastic's passes)",
                self.passes
            )));
        }
        Ok(())
    }
}

/// `--weight`.
pub const WEIGHT: MethodOption = MethodOption::named("weight");
/// `--moments`.
pub const MOMENTS: MethodOption = MethodOption::named("moments");
/// `--passes`.
pub const PASSES: MethodOption = MethodOption::named("passes");
/// `--coefficients`.
pub const COEFFICIENTS: MethodOption = MethodOption::named("coefficients");
/// `--opacity`.
pub const OPACITY: MethodOption = MethodOption::named("opacity");

/// The weighted family's options (`--weight` and `--depth-scale` also weigh a k-buffer's
/// `--tail weighted`).
pub const OPTIONS: &[OptionSpec] = &[
    OptionSpec {
        option: WEIGHT,
        flags: &[
            flag(
                "weight",
                "--weight",
                "wboit (and --tail weighted): the weight function (McGuire & Bavoil 2013, equations 7-10)",
                ValueKind::Choice(Weight::NAMES),
                |f| Some(f.family::<WeightedOptions>().weight.name().to_string()),
                |f, v| {
 f.family_mut::<WeightedOptions>().weight = parse::<Weight>("--weight", v)?;
 Ok(())
 },
            ),
            flag(
                "depth_scale",
                "--depth-scale",
                "wboit (and --tail weighted): multiplies view-space distances before the weight function (its constants assume distances of 0.1 to 500 units)",
                ValueKind::Number {
                    min: 1e-4,
                    max: 1e4,
                },
                |f| Some(f.family::<WeightedOptions>().depth_scale.to_string()),
                |f, v| {
 f.family_mut::<WeightedOptions>().depth_scale = parse("--depth-scale", v)?;
 Ok(())
 },
            ),
        ],
    },
    OptionSpec {
        option: MOMENTS,
        flags: &[flag(
            "moments",
            "--moments",
            "mboit: power moments, 4, 6 or 8 (more follow more layers, at more memory and work), or trigonometric moments, trig2, trig3 or trig4 (as many real values as 4, 6, 8)",
            ValueKind::Choice(&["4", "6", "8", "trig2", "trig3", "trig4"]),
            |f| Some(f.family::<WeightedOptions>().moments.to_string()),
            |f, v| {
 f.family_mut::<WeightedOptions>().moments = v.unwrap_or_default().parse::<Moments>()?;
 Ok(())
 },
        )],
    },
    OptionSpec {
        option: PASSES,
        flags: &[flag(
            "passes",
            "--passes",
            "stochastic: passes of S samples each (more passes, less noise; 2·passes + 1 geometry passes)",
            ValueKind::Count {
                min: 1,
                max: MAX_STOCHASTIC_PASSES,
            },
            |f| Some(f.family::<WeightedOptions>().passes.to_string()),
            |f, v| {
 f.family_mut::<WeightedOptions>().passes = parse("--passes", v)?;
 Ok(())
 },
        )],
    },
    OptionSpec {
        option: COEFFICIENTS,
        flags: &[flag(
            "coefficients",
            "--coefficients",
            "wavelet: Haar coefficients of each pixel's absorbance over depth, 4 or 8 (its depth range in 4 or 8 bins)",
            ValueKind::Choice(&["4", "8"]),
            |f| Some(f.family::<WeightedOptions>().coefficients.to_string()),
            |f, v| {
 f.family_mut::<WeightedOptions>().coefficients = parse("--coefficients", v)?;
 Ok(())
 },
        )],
    },
    OptionSpec {
        option: OPACITY,
        flags: &[flag(
            "opacity",
            "--opacity",
            "wavg: a pixel's opacity from its fragments' average opacity, 1 - (1 - mean alpha)^n (average, the paper's), or their exact product 1 - prod(1 - alpha) (product)",
            ValueKind::Choice(Opacity::NAMES),
            |f| Some(f.family::<WeightedOptions>().opacity.name().to_string()),
            |f, v| {
                f.family_mut::<WeightedOptions>().opacity = parse::<Opacity>("--opacity", v)?;
                Ok(())
            },
        )],
    },
];
