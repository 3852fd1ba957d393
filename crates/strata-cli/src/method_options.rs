//! Which method options each method reads: the viewer greys out the others, and `strata
//! render` refuses them when given (an option that silently does nothing misleads).

use strata::methods::{MethodId, MethodOption};

use crate::{MethodArgs, PictureArgs, PipelineArg, Toggle};
use strata::error::{Error, Result};

/// An option that only some methods or pipelines read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Opt {
    /// `--k`: how many fragments a pixel keeps.
    K,
    /// `--tail`: what becomes of the fragments past k.
    Tail,
    /// `--culling`: the k-buffers' test against a full pixel's farthest fragment.
    Culling,
    MaxTries,
    Layers,
    LayersPerPass,
    HeapSize,
    /// `--buckets`: bucket's split.
    Buckets,
    /// `--weight` and `--depth-scale`.
    Weight,
    Moments,
    RasterCompute,
    Budget,
    Tonemap,
    Deferred,
    /// `--order`: every method but `sorted` (its own order) and `f2b` (ties in draw order).
    Order,
    /// `--temporal`: the slot k-buffers that choose at capture time.
    Temporal,
    /// `--msaa`: every method but the 8-byte multi-depth tests (with a pipeline too: the
    /// transparent surfaces are anti-aliased over the lit frame).
    Msaa,
    /// `--cache-dir`: the preprocesses kept between runs (convex's decomposition).
    CacheDir,
}

/// Whether `method` (with `pipeline`) reads option `opt`.
pub fn applies(opt: Opt, method: MethodId, pipeline: Option<PipelineArg>) -> bool {
    let d = method.descriptor();
    let reads = |o: MethodOption| d.reads(o);
    match opt {
        Opt::K => reads(MethodOption::K),
        Opt::Tail => reads(MethodOption::Tail),
        Opt::Culling => reads(MethodOption::Culling),
        Opt::MaxTries => reads(MethodOption::MaxTries),
        Opt::Layers => reads(MethodOption::Layers),
        Opt::LayersPerPass => reads(MethodOption::LayersPerPass),
        Opt::HeapSize => reads(MethodOption::HeapSize),
        Opt::Buckets => reads(MethodOption::Buckets),
        Opt::Weight => reads(MethodOption::Weight),
        Opt::Moments => reads(MethodOption::Moments),
        Opt::CacheDir => reads(MethodOption::CacheDir),
        Opt::RasterCompute => d.compute_raster.yes(),
        // Every GPU method's allocations are checked against it.
        Opt::Budget => method != MethodId::Reference,
        Opt::Tonemap => matches!(pipeline, Some(PipelineArg::Forward | PipelineArg::Deferred)),
        Opt::Deferred => pipeline == Some(PipelineArg::Deferred),
        Opt::Order => d.takes_order,
        Opt::Temporal => d.temporal,
        Opt::Msaa => d.msaa.yes(),
    }
}

/// The options of `render` that only some methods read, with the option each belongs to:
/// (clap id, flag, option).
const METHOD_FLAGS: [(&str, &str, Opt); 12] = [
    ("k", "--k", Opt::K),
    ("tail", "--tail", Opt::Tail),
    ("culling", "--culling", Opt::Culling),
    ("max_tries", "--max-tries", Opt::MaxTries),
    ("layers", "--layers", Opt::Layers),
    ("heap_size", "--heap-size", Opt::HeapSize),
    ("buckets", "--buckets", Opt::Buckets),
    ("weight", "--weight", Opt::Weight),
    ("depth_scale", "--depth-scale", Opt::Weight),
    ("moments", "--moments", Opt::Moments),
    ("budget_mb", "--budget-mb", Opt::Budget),
    ("cache_dir", "--cache-dir", Opt::CacheDir),
];

/// Refuses an option given on the command line (`a.given`) that the method does not read,
/// naming the methods that do.
pub fn check_given(a: &MethodArgs, picture: &PictureArgs) -> Result<()> {
    let given = |id: &str| a.given.iter().any(|g| g == id);
    let refuse = |flag: &str, opt: Opt| {
        let readers: Vec<&str> = MethodId::all()
            .filter(|&m| applies(opt, m, picture.pipeline))
            .map(MethodId::as_str)
            .collect();
        Err(Error::input(format!(
            "{flag} does not apply to {}; it applies to {}",
            a.method,
            readers.join(", ")
        )))
    };
    for (id, flag, opt) in METHOD_FLAGS {
        if given(id) && !applies(opt, a.method, picture.pipeline) {
            return refuse(flag, opt);
        }
    }
    if given("seed") && a.order != Some(strata::order::Order::Random) {
        return Err(Error::input("--seed applies to --order random"));
    }
    for (id, flag) in [
        ("temporal_refresh", "--temporal-refresh"),
        ("temporal_epsilon", "--temporal-epsilon"),
    ] {
        if given(id) && a.temporal != Toggle::On {
            return Err(Error::input(format!("{flag} applies to --temporal on")));
        }
    }
    Ok(())
}
