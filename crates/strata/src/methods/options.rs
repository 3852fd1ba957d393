//! One spec per method option: the flags that set it, each with its help, the values it takes
//! (which the viewer's widget offers), how it is read from and written into a frame's options,
//! and so how a frame's value of it is written back on a `strata render` line. Each family
//! declares its own options' specs beside its descriptors (`OPTIONS` in its `descriptor.rs`;
//! [`super::option_specs`] lists them all); the values live in the family's options struct
//! (`KBufferOptions`, `PeelingOptions`, `WeightedOptions`, each in its folder's `options.rs`,
//! which checks their ranges), carried by [`FrameOptions::families`].
//! The CLI's arguments, its refusal of an option the method does not read, the viewer's
//! widgets and its command line are made from these.

use std::str::FromStr;

use crate::error::{Error, Result};
use crate::frame::FrameOptions;

/// A parameter that only some methods read (`Descriptor::reads`), known by its name: each family
/// declares its own beside its options (`kbuffer::options::TAIL`), the ones several families
/// share are here ([`K`], [`LAYERS_PER_PASS`]).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct MethodOption(&'static str);

impl MethodOption {
    /// The option called `name` (its main flag without the dashes).
    pub const fn named(name: &'static str) -> MethodOption {
        MethodOption(name)
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        self.0
    }
}

impl std::fmt::Debug for MethodOption {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "--{}", self.0)
    }
}

/// `--k`: how many fragments a pixel keeps.
pub const K: MethodOption = MethodOption::named("k");

/// `--layers-per-pass`: kpeel's other name for k.
pub const LAYERS_PER_PASS: MethodOption = MethodOption::named("layers-per-pass");

/// One method option: the flags that set it.
#[derive(Clone, Copy, Debug)]
pub struct OptionSpec {
    /// The option, as descriptors list it in `reads`.
    pub option: MethodOption,
    /// The flags that set it.
    pub flags: &'static [Flag],
}

/// A command-line flag of a method option.
#[derive(Clone, Copy, Debug)]
pub struct Flag {
    /// clap's id of its argument (`heap_size`).
    pub id: &'static str,
    /// The flag (`--heap-size`).
    pub flag: &'static str,
    /// Its help line.
    pub help: &'static str,
    /// Its values, and how they are read and set; `None` where the CLI keeps the flag itself
    /// (`--k`, which takes `auto`; `--layers-per-pass`, kpeel's other name for k; `--cache-dir`,
    /// a path made absolute).
    pub value: Option<FlagValue>,
}

/// What a flag takes and where its value lives in a frame's options.
#[derive(Clone, Copy, Debug)]
pub struct FlagValue {
    /// The values it takes.
    pub kind: ValueKind,
    /// Its value in `frame`, as the command line writes it (`None`: unset, the method's own
    /// choice).
    pub get: fn(&FrameOptions) -> Option<String>,
    /// Sets it in `frame` from the command line's text (`None`: unset); an error names the flag.
    pub set: fn(&mut FrameOptions, Option<&str>) -> Result<()>,
}

/// The values a flag takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ValueKind {
    /// One of these words.
    Choice(&'static [&'static str]),
    /// A whole number in `min..=max`.
    Count {
        /// The least.
        min: u32,
        /// The most.
        max: u32,
    },
    /// A whole number in `min..=max`, or unset (the method decides).
    Optional {
        /// The least.
        min: u32,
        /// The most.
        max: u32,
        /// What the viewer offers when it is set.
        start: u32,
    },
    /// A number in `min..=max`.
    Number {
        /// The least.
        min: f64,
        /// The most.
        max: f64,
    },
}

/// A flag the CLI keeps itself (see [`Flag::value`]).
pub const fn kept_flag(id: &'static str, flag: &'static str, help: &'static str) -> Flag {
    Flag {
        id,
        flag,
        help,
        value: None,
    }
}

/// A flag whose value the spec reads and sets.
pub const fn flag(
    id: &'static str,
    flag: &'static str,
    help: &'static str,
    kind: ValueKind,
    get: fn(&FrameOptions) -> Option<String>,
    set: fn(&mut FrameOptions, Option<&str>) -> Result<()>,
) -> Flag {
    Flag {
        id,
        flag,
        help,
        value: Some(FlagValue { kind, get, set }),
    }
}

/// `text` parsed as a `T` for `flag`, or one line naming the flag and the text (the type's own
/// refusal where it names the flag: a keyword's lists its words).
pub fn parse<T: FromStr>(flag: &str, text: Option<&str>) -> Result<T>
where
    T::Err: std::fmt::Display,
{
    let text = text.ok_or_else(|| Error::input(format!("{flag} takes a value")))?;
    text.trim().parse().map_err(|e: T::Err| {
        let why = e.to_string();
        match why.contains(flag) {
            true => Error::input(why),
            false => Error::input(format!(
                "{flag} '{}' is not a valid value ({why})",
                crate::error::quoted(text)
            )),
        }
    })
}

/// `text` parsed as a `T` for `flag`, or unset when there is none.
pub fn parse_optional<T: FromStr>(flag: &str, text: Option<&str>) -> Result<Option<T>>
where
    T::Err: std::fmt::Display,
{
    text.map(|t| parse(flag, Some(t))).transpose()
}

impl Flag {
    /// The flag's name without its dashes (`heap-size`).
    pub fn name(&self) -> &'static str {
        self.flag.trim_start_matches('-')
    }
}

impl OptionSpec {
    /// The flags (without their dashes) and values that give `frame`'s value of this option on
    /// a `strata render` line: none where it has its default.
    pub fn written(&self, frame: &FrameOptions) -> Vec<(&'static str, String)> {
        let default = FrameOptions::default();
        self.flags
            .iter()
            .filter_map(|f| {
                let v = f.value?;
                let value = (v.get)(frame)?;
                ((v.get)(&default).as_ref() != Some(&value)).then_some((f.name(), value))
            })
            .collect()
    }
}

impl MethodOption {
    /// The option's spec.
    pub fn spec(self) -> &'static OptionSpec {
        super::option_specs()
            .find(|s| s.option == self)
            .expect("every method option has a spec (each_method_option_has_one_spec)")
    }
}

/// Every flag of every method option, with its option.
pub fn flags() -> impl Iterator<Item = (&'static Flag, MethodOption)> {
    super::option_specs().flat_map(|s| s.flags.iter().map(move |f| (f, s.option)))
}

/// The options every family with a k shares: `--k` and kpeel's other name for it (both kept by
/// the CLI: `--k` takes `auto`, and the picture's options write it).
pub(super) const SHARED: &[OptionSpec] = &[
    OptionSpec {
        option: K,
        flags: &[kept_flag("k", "--k", "fragments kept per pixel")],
    },
    OptionSpec {
        option: LAYERS_PER_PASS,
        flags: &[kept_flag(
            "layers_per_pass",
            "--layers-per-pass",
            "kpeel: layers captured per geometry pass",
        )],
    },
];

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
            assert_eq!(
                spec.flags.first().map(|f| f.name()),
                Some(spec.option.name()),
                "an option is named as its first flag"
            );
            for f in spec.flags {
                assert_eq!(f.flag, format!("--{}", f.id.replace('_', "-")), "{f:?}");
                assert!(!f.help.is_empty(), "{f:?}");
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
        let frame = FrameOptions::default();
        for spec in super::super::option_specs() {
            assert_eq!(spec.written(&frame), Vec::new(), "{:?}", spec.option);
        }
    }

    /// Every value a flag offers sets, reads back as itself and validates; unset, where it
    /// may be, reads back unset; text that is not a value is refused naming the flag.
    #[test]
    fn each_flag_sets_what_it_reads() {
        for (f, _) in flags() {
            let Some(v) = f.value else { continue };
            let values: Vec<String> = match v.kind {
                ValueKind::Choice(words) => words.iter().map(|w| w.to_string()).collect(),
                ValueKind::Count { min, max } | ValueKind::Optional { min, max, .. } => {
                    vec![min.to_string(), max.to_string()]
                }
                ValueKind::Number { min, max } => vec![min.to_string(), max.to_string()],
            };
            for value in values {
                let mut frame = FrameOptions::default();
                (v.set)(&mut frame, Some(&value)).unwrap_or_else(|e| panic!("{f:?} {value}: {e}"));
                assert_eq!(
                    (v.get)(&frame).as_deref(),
                    Some(value.as_str()),
                    "{}",
                    f.flag
                );
                frame
                    .validate()
                    .unwrap_or_else(|e| panic!("{} {value}: {e}", f.flag));
            }
            if let ValueKind::Optional { .. } = v.kind {
                let mut frame = FrameOptions::default();
                (v.set)(&mut frame, Some("3")).unwrap();
                (v.set)(&mut frame, None).unwrap();
                assert_eq!((v.get)(&frame), None, "{}", f.flag);
            }
            let mut frame = FrameOptions::default();
            let e = (v.set)(&mut frame, Some("bogus")).unwrap_err().to_string();
            assert!(e.contains(f.flag) && e.contains("bogus"), "{e}");
        }
    }

    /// `--weight` is read by the weighted methods, and by a k-buffer whose tail is weighted.
    #[test]
    fn a_weighted_tail_reads_the_weight() {
        use crate::methods::MethodId;
        let mut frame = FrameOptions::default();
        let reads = |id: MethodId, frame: &FrameOptions| {
            id.descriptor()
                .reads_with(crate::methods::weighted::options::WEIGHT, frame)
        };
        assert!(reads(MethodId::Wboit, &frame));
        assert!(!reads(MethodId::KplusArray, &frame));
        frame
            .family_mut::<crate::methods::kbuffer::KBufferOptions>()
            .tail = crate::methods::kbuffer::Tail::Weighted;
        assert!(reads(MethodId::KplusArray, &frame));
        assert!(
            !reads(MethodId::AbufferLl, &frame),
            "abuffer-ll keeps no tail"
        );
    }
}
