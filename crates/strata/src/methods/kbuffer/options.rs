//! The k-buffer family's options (`--tail`, `--culling`, `--max-tries`, `--storage-layout`,
//! `--heap-size`, the linked lists' pool): the values a frame carries for it
//! (`frame.family::<KBufferOptions>()`), their defaults and ranges. Their flags' specs
//! (`OPTIONS`) and names (`MethodOption`s, which descriptors list in `reads`) are here too.

use crate::error::{Error, Result};
use crate::frame::FamilyOption;
use crate::keyword::keyword_enum;
use crate::methods::options::{flag, parse, parse_optional, MethodOption, OptionSpec, ValueKind};

/// The most tries `--max-tries` accepts: every waiting fragment spins at most this long, a bound
/// that keeps a starving pixel within a frame's time instead of the driver's reset.
pub const MAX_TRIES_LIMIT: u32 = 1 << 20;

keyword_enum! {
    /// What k-buffer methods do with fragments beyond the k nearest.
    #[derive(Default)]
    pub enum Tail ("--tail") {
        /// Discard them (counted in `fragments_dropped`).
        #[default]
        Drop = "drop",
        /// Blend them, unsorted, into one tail term behind the k nearest (weighted average color,
        /// opacity from the sum of their optical depths), as engines do.
        Blend = "blend",
        /// Hybrid transparency (Maule et al. 2013): the tail as weighted blended OIT — its color the
        /// average weighted by α·w(z) of McGuire & Bavoil's equations (`--weight`, `--depth-scale`),
        /// its opacity as `blend`'s — behind the k nearest, so nearer tail fragments count more.
        Weighted = "weighted",
    }
}

impl Tail {
    /// Whether fragments beyond k are kept as a tail term (blended or weighted).
    pub fn kept(self) -> bool {
        self != Tail::Drop
    }
}

keyword_enum! {
    /// How the k-buffer family lays out its per-pixel arrays (`--storage-layout`): the words of
    /// each pixel (seen, filled, lock, bound), its slots and its tail sums.
    #[derive(Default)]
    pub enum StorageLayout ("--storage-layout") {
        /// Each pixel's items together (`p · items + i`), as the papers draw their per-pixel
        /// arrays: one pixel's walk over its slots stays within a few cache lines.
        #[default]
        Pixel = "pixel",
        /// Item i of every pixel together (`i · pixels + p`): the neighbouring pixels that a
        /// GPU shades in one warp touch neighbouring words, so a warp's access is a few memory
        /// transactions instead of one per pixel.
        Slot = "slot",
    }
}

impl StorageLayout {
    /// Where item `i` of storage pixel `p`'s `per_pixel` items lies in an array of
    /// `storage_pixels` pixels' items: the CPU twin of `pixel_item` in storage.wgsl.
    pub fn item(self, p: u64, i: u64, per_pixel: u64, storage_pixels: u64) -> u64 {
        match self {
            StorageLayout::Slot => i * storage_pixels + p,
            StorageLayout::Pixel => p * per_pixel + i,
        }
    }
}

/// The k-buffer family's parameters (and the linked lists' pools, which share its storage code).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KBufferOptions {
    /// Fragments beyond k.
    pub tail: Tail,
    /// Cull fragments behind a full pixel's maximum before taking the lock.
    pub culling: bool,
    /// Lock and compare-exchange tries per shader invocation (default 65536, at most
    /// [`MAX_TRIES_LIMIT`]): per fragment under the GPU's rasterizer, shared by the up to 64
    /// fragments an invocation of the compute rasterizer captures (each gets at least one try).
    pub max_tries: Option<u32>,
    /// How the per-pixel arrays are laid out.
    pub layout: StorageLayout,
    /// kplus-semiheap: slots of the max-heap H (default 1, the paper's), the rest unordered.
    pub heap_size: Option<u32>,
    /// Initial node pool of the linked-list methods (nodes); by default sized from the last
    /// frame's measured need.
    pub initial_nodes: Option<u64>,
    /// Value the fragment-pool allocation counters start from each frame (normally 0). Tests
    /// start them near 2³² to show that they saturate instead of wrapping.
    pub allocation_counter_start: u32,
}

impl Default for KBufferOptions {
    fn default() -> Self {
        KBufferOptions {
            tail: Tail::Drop,
            culling: true,
            max_tries: None,
            layout: StorageLayout::Pixel,
            heap_size: None,
            initial_nodes: None,
            allocation_counter_start: 0,
        }
    }
}

impl FamilyOption for KBufferOptions {
    fn validate(&self) -> Result<()> {
        match self.max_tries {
            Some(0) => Err(Error::input("--max-tries must be at least 1")),
            Some(tries) if tries > MAX_TRIES_LIMIT => Err(Error::input(format!(
                "--max-tries {tries} is over {MAX_TRIES_LIMIT}: an invocation spinning that long on a starved lock could outlast the GPU's watchdog"
            ))),
            _ => Ok(()),
        }
    }
}

/// `--tail`.
pub const TAIL: MethodOption = MethodOption::named("tail");
/// `--culling`.
pub const CULLING: MethodOption = MethodOption::named("culling");
/// `--max-tries`.
pub const MAX_TRIES: MethodOption = MethodOption::named("max-tries");
/// `--storage-layout`.
pub const STORAGE_LAYOUT: MethodOption = MethodOption::named("storage-layout");
/// `--heap-size`.
pub const HEAP_SIZE: MethodOption = MethodOption::named("heap-size");

/// The k-buffer family's options (`--k` is every k method's: `methods::options`).
pub const OPTIONS: &[OptionSpec] = &[
    OptionSpec {
        option: TAIL,
        flags: &[flag(
            "tail",
            "--tail",
            "fragments beyond k (k-buffer methods): dropped, blended into one term behind the k nearest, or weighted as wboit weighs them (--weight, --depth-scale)",
            ValueKind::Choice(Tail::NAMES),
            |f| Some(f.family::<KBufferOptions>().tail.name().to_string()),
            |f, v| {
 f.family_mut::<KBufferOptions>().tail = parse::<Tail>("--tail", v)?;
 Ok(())
 },
        )],
    },
    OptionSpec {
        option: CULLING,
        flags: &[flag(
            "culling",
            "--culling",
            "k-buffers cull fragments behind a full pixel's farthest before taking the lock",
            ValueKind::Choice(&["on", "off"]),
            |f| Some(if f.family::<KBufferOptions>().culling { "on" } else { "off" }.to_string()),
            |f, v| {
                f.family_mut::<KBufferOptions>().culling = match v {
                    Some("on") => true,
                    Some("off") => false,
                    other => return Err(not_on_or_off("--culling", other)),
                };
                Ok(())
            },
        )],
    },
    OptionSpec {
        option: MAX_TRIES,
        flags: &[flag(
            "max_tries",
            "--max-tries",
            "lock tries per shader invocation for the locking k-buffers and kb-ll (default 65536, at most 1048576): per fragment, shared by an invocation's fragments under --raster compute",
            ValueKind::Optional {
                min: 1,
                max: crate::methods::kbuffer::MAX_TRIES_LIMIT,
                start: super::DEFAULT_MAX_TRIES,
            },
            |f| f.family::<KBufferOptions>().max_tries.map(|t| t.to_string()),
            |f, v| {
 f.family_mut::<KBufferOptions>().max_tries = parse_optional("--max-tries", v)?;
 Ok(())
 },
        )],
    },
    OptionSpec {
        option: STORAGE_LAYOUT,
        flags: &[flag(
            "storage_layout",
            "--storage-layout",
            "the k-buffers' and A-buffers' per-pixel arrays: pixel (each pixel's items together, as the papers draw them) or slot (item i of every pixel together, so that the neighbouring pixels of a GPU warp share memory transactions; see `strata bench kbuffer-layout`)",
            ValueKind::Choice(StorageLayout::NAMES),
            |f| Some(f.family::<KBufferOptions>().layout.name().to_string()),
            |f, v| {
 f.family_mut::<KBufferOptions>().layout = parse::<StorageLayout>("--storage-layout", v)?;
 Ok(())
 },
        )],
    },
    OptionSpec {
        option: HEAP_SIZE,
        flags: &[flag(
            "heap_size",
            "--heap-size",
            "kplus-semiheap: slots of its max-heap (default 1, the paper's); the other k - h are unordered",
            ValueKind::Optional {
                min: 1,
                max: 1024,
                start: 1,
            },
            |f| f.family::<KBufferOptions>().heap_size.map(|h| h.to_string()),
            |f, v| {
 f.family_mut::<KBufferOptions>().heap_size = parse_optional("--heap-size", v)?;
 Ok(())
 },
        )],
    },
];

/// One line refusing `text` for an on/off flag.
fn not_on_or_off(flag: &str, text: Option<&str>) -> crate::error::Error {
    crate::error::Error::input(format!(
        "{flag} '{}' is neither on nor off",
        crate::error::quoted(text.unwrap_or(""))
    ))
}
