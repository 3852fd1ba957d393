//! The families' method options on the command line, made from their specs
//! (`strata::methods::options`): each flag's argument, help and accepted words come from its
//! spec, and its value is set into the family's part of `FrameOptions` by the spec. A new
//! option of a family needs nothing here.

use strata::frame::FrameOptions;
use strata::methods::options::{flags, Flag, ValueKind};
use strata::methods::MethodOption;

/// The family options given (the rest at their defaults), in the frame options' family parts
/// (`FrameOptions::families`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FamilyArgs {
    pub frame: FrameOptions,
}

impl FamilyArgs {
    /// Sets `frame`'s family parts to these.
    pub fn apply(&self, frame: &mut FrameOptions) {
        frame.families = self.frame.families.clone();
    }
}

/// The flags whose values the specs set.
fn valued() -> impl Iterator<Item = (&'static Flag, MethodOption)> {
    flags().filter(|(f, _)| f.value.is_some())
}

/// The flag's help, with the methods that read it (from the method table).
fn help(f: &Flag, option: MethodOption) -> String {
    let readers: Vec<&str> = strata::methods::TABLE
        .iter()
        .filter(|d| d.reads(option))
        .map(|d| d.name)
        .collect();
    let values = match f.value.map(|v| v.kind) {
        Some(ValueKind::Choice(words)) => format!(" [values: {}]", words.join(", ")),
        _ => String::new(),
    };
    format!("{}{values} [read by: {}]", f.help, readers.join(", "))
}

impl clap::Args for FamilyArgs {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        valued().fold(cmd, |cmd, (f, option)| {
            // Every value is parsed by its spec, whose refusal names the flag and what it
            // takes; the words a choice takes are listed in its help.
            let arg = clap::Arg::new(f.id)
                .long(f.name())
                .help(help(f, option))
                .action(clap::ArgAction::Set)
                .value_parser(clap::value_parser!(String));
            cmd.arg(arg)
        })
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

impl clap::FromArgMatches for FamilyArgs {
    fn from_arg_matches(matches: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let mut args = FamilyArgs::default();
        args.update_from_arg_matches(matches)?;
        Ok(args)
    }

    fn update_from_arg_matches(&mut self, matches: &clap::ArgMatches) -> Result<(), clap::Error> {
        for (f, _) in valued() {
            let value = f.value.expect("valued");
            if let Some(text) = matches.get_one::<String>(f.id) {
                (value.set)(&mut self.frame, Some(text)).map_err(|e| {
                    clap::Error::raw(clap::error::ErrorKind::ValueValidation, format!("{e}\n"))
                })?;
            }
        }
        Ok(())
    }
}
