//! Which method options each method reads: the viewer greys out the others, and `strata
//! render` refuses them when given (an option that silently does nothing misleads).

use strata::methods::{MethodId, MethodOption};

use crate::{MethodArgs, PictureArgs, PipelineArg, Toggle};
use strata::error::{Error, Result};

/// An option that only some methods or pipelines read: a method parameter (the method's
/// descriptor lists those it reads), or one that a capability or the pipeline decides.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(not(feature = "view"), allow(dead_code))]
pub enum Opt {
    Method(MethodOption),
    /// `--raster compute`.
    RasterCompute,
    /// `--budget-mb`: every GPU method's allocations are checked against it.
    Budget,
    /// `--tonemap` (the lit pipelines).
    Tonemap,
    /// The deferred pipeline's options.
    Deferred,
    /// `--order`: every method but those with an order of their own.
    Order,
    /// `--temporal`: the slot k-buffers that choose at capture time.
    Temporal,
    /// `--msaa` (with a pipeline too: the transparent surfaces are anti-aliased over the lit
    /// frame).
    Msaa,
}

#[cfg_attr(not(feature = "view"), allow(dead_code))]
impl Opt {
    pub const K: Opt = Opt::Method(strata::methods::options::K);
    pub const TAIL: Opt = Opt::Method(strata::methods::kbuffer::options::TAIL);
    pub const LAYERS_PER_PASS: Opt = Opt::Method(strata::methods::options::LAYERS_PER_PASS);
    pub const WEIGHT: Opt = Opt::Method(strata::methods::weighted::options::WEIGHT);
}

/// Whether `method` (with `pipeline`) reads option `opt`.
pub fn applies(opt: Opt, method: MethodId, pipeline: Option<PipelineArg>) -> bool {
    let d = method.descriptor();
    match opt {
        Opt::Method(o) => d.reads(o),
        Opt::RasterCompute => d.compute_raster.yes(),
        Opt::Budget => method != MethodId::Reference,
        Opt::Tonemap => matches!(pipeline, Some(PipelineArg::Forward | PipelineArg::Deferred)),
        Opt::Deferred => pipeline == Some(PipelineArg::Deferred),
        Opt::Order => d.takes_order,
        Opt::Temporal => d.temporal,
        Opt::Msaa => d.msaa.yes(),
    }
}

/// Refuses an option given on the command line (`a.given`) that the method does not read,
/// naming the methods that do.
pub fn check_given(a: &MethodArgs, picture: &PictureArgs) -> Result<()> {
    let given = |id: &str| a.given.iter().any(|g| g == id);
    let refuse = |flag: &str, opt: Opt| {
        let readers: Vec<&str> = MethodId::all()
            .filter(|&m| applies(opt, m, picture.pipeline))
            .map(MethodId::as_str)
            .collect();
        let tails = if opt == Opt::WEIGHT {
            " (and, with --tail weighted, to the k-buffers)"
        } else {
            ""
        };
        Err(Error::input(format!(
            "{flag} does not apply to {}; it applies to {}{tails}",
            a.id(),
            readers.join(", ")
        )))
    };
    // Each method option's flags come from its spec (`strata::methods::options`); whether the
    // method reads it, from its descriptor.
    let d = a.id().descriptor();
    for (f, option) in strata::methods::options::flags() {
        if given(f.id) && !d.reads_with(option, &a.family.frame) {
            return refuse(f.flag, Opt::Method(option));
        }
    }
    if given("budget_mb") && !applies(Opt::Budget, a.id(), picture.pipeline) {
        return refuse("--budget-mb", Opt::Budget);
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

#[cfg(test)]
mod tests {
    /// Every flag a method option's spec names is an argument of `render` and of `view` under
    /// the same clap id, so the refusal and the viewer's command line name real flags.
    #[test]
    fn every_spec_flag_is_an_argument_of_render_and_view() {
        let command = crate::command();
        for sub in ["render", "view"] {
            let sub = command.find_subcommand(sub).expect("the subcommand");
            for spec in strata::methods::option_specs() {
                for f in spec.flags {
                    let arg = sub.get_arguments().find(|a| a.get_id() == f.id);
                    let arg = arg.unwrap_or_else(|| panic!("{} has no {}", sub.get_name(), f.id));
                    assert_eq!(
                        arg.get_long().map(|l| format!("--{l}")).as_deref(),
                        Some(f.flag)
                    );
                }
            }
        }
    }
}
