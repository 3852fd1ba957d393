//! One spec per method option: the flags that set it on a `strata render` line and how a
//! frame's value of it is written back as flags. Each family declares its own options' specs
//! beside its descriptors (`OPTIONS` in its `descriptor.rs`; [`super::option_specs`] lists
//! them all); the option values live in the
//! family's part of [`crate::frame::FrameOptions`]. The CLI's refusal of an option the method
//! does not read and the viewer's command line are made from these.

use crate::frame::RenderOptions;

use super::table::MethodOption;

/// A command-line flag and the id clap gives its argument.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Flag {
    /// clap's id of the argument (the field's name: `heap_size`).
    pub id: &'static str,
    /// The flag (`--heap-size`).
    pub flag: &'static str,
}

/// The flag `--name` whose clap id is `name` with dashes as underscores.
pub const fn flag(id: &'static str, flag: &'static str) -> Flag {
    Flag { id, flag }
}

/// One method option.
#[derive(Clone, Copy, Debug)]
pub struct OptionSpec {
    /// The option, as descriptors list it in `reads`.
    pub option: MethodOption,
    /// The flags that set it.
    pub flags: &'static [Flag],
    /// The flags (without their dashes) and values that give `options`' value of it on a
    /// `strata render` line: none where it has its default.
    pub written: fn(&RenderOptions) -> Vec<(&'static str, String)>,
}

impl MethodOption {
    /// The option's spec.
    pub fn spec(self) -> &'static OptionSpec {
        super::option_specs()
            .find(|s| s.option == self)
            .expect("every method option has a spec (each_method_option_has_one_spec)")
    }
}

/// The options every family with a k shares: `--k` (written with the picture's options, which
/// take `auto` too) and kpeel's other name for it.
pub(super) const SHARED: &[OptionSpec] = &[
    OptionSpec {
        option: MethodOption::K,
        flags: &[flag("k", "--k")],
        written: |_| Vec::new(),
    },
    OptionSpec {
        option: MethodOption::LayersPerPass,
        flags: &[flag("layers_per_pass", "--layers-per-pass")],
        written: |_| Vec::new(),
    },
];

/// `(name, value)` when `value` differs from `default`.
pub fn unless_default<T: PartialEq + ToString>(
    name: &'static str,
    value: T,
    default: T,
) -> Vec<(&'static str, String)> {
    match value == default {
        true => Vec::new(),
        false => vec![(name, value.to_string())],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_method_option_has_one_spec() {
        use std::collections::BTreeSet;
        let mut seen = BTreeSet::new();
        for spec in super::super::option_specs() {
            assert!(
                seen.insert(format!("{:?}", spec.option)),
                "{:?} twice",
                spec.option
            );
            for f in spec.flags {
                assert_eq!(f.flag, format!("--{}", f.id.replace('_', "-")), "{f:?}");
            }
        }
        for d in super::super::TABLE {
            for option in d.reads {
                assert_eq!(option.spec().option, *option, "{}", d.name);
            }
        }
    }

    /// Default options write nothing: a command line names only what was changed.
    #[test]
    fn default_options_write_no_flags() {
        let options = RenderOptions::default();
        for spec in super::super::option_specs() {
            assert_eq!((spec.written)(&options), Vec::new(), "{:?}", spec.option);
        }
    }
}
