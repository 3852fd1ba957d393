//! Enums whose values are words: on the command line, in scene files and in statistics. One
//! declaration ([`keyword_enum!`]) gives such an enum its word per value (`name()`), the list of
//! its values (`ALL`), its number as the shaders read it (`index()`, the declaration order), and
//! a `FromStr` whose error is one line listing the words.

use crate::error::{quoted, Error, Result};

/// `value` as one of `all`'s words, or an input error naming `what` and listing the words.
pub(crate) fn parse<T: Copy>(
    value: &str,
    what: &str,
    all: &[T],
    name: fn(T) -> &'static str,
) -> Result<T> {
    all.iter()
        .copied()
        .find(|v| name(*v) == value)
        .ok_or_else(|| {
            let words: Vec<&str> = all.iter().map(|v| name(*v)).collect();
            Error::input(format!(
                "unknown {what} '{}' (expected {})",
                quoted(value),
                one_of(&words)
            ))
        })
}

/// "a", "a or b", "a, b or c".
pub(crate) fn one_of(words: &[&str]) -> String {
    match words.split_last() {
        None => String::new(),
        Some((last, [])) => last.to_string(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
    }
}

/// Declares a plain enum of words: `enum Name ("what the error calls it") { Value = "word", … }`.
/// It derives `Clone, Copy, Debug, PartialEq, Eq` (more with the caller's own `#[derive]`),
/// `Serialize` under the words in lowercase (the `serde` feature) and `clap::ValueEnum` (the
/// `clap` feature), so a word must be its value's name in lowercase.
macro_rules! keyword_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident ($what:literal) {
            $( $(#[$value_meta:meta])* $value:ident = $word:literal, )+
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        #[cfg_attr(feature = "serde", derive(serde::Serialize))]
        #[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
        #[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
        $vis enum $name {
            $( $(#[$value_meta])* $value, )+
        }

        impl $name {
            /// Every value, in declaration order.
            pub const ALL: &'static [$name] = &[$($name::$value),+];

            /// Every value's word, in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($word),+];

            /// The value's word on the command line, in scene files and in statistics.
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$value => $word,)+
                }
            }

            /// The value's number as the shaders read it: its place in the declaration.
            pub fn index(self) -> u32 {
                self as u32
            }
        }

        impl std::str::FromStr for $name {
            type Err = $crate::error::Error;
            fn from_str(s: &str) -> $crate::error::Result<Self> {
                $crate::keyword::parse(s, $what, $name::ALL, $name::name)
            }
        }
    };
}
pub(crate) use keyword_enum;

#[cfg(test)]
mod tests {
    use super::*;

    keyword_enum! {
        /// A test enum.
        #[derive(Default)]
        enum Fruit ("--fruit") {
            /// The first.
            #[default]
            Apple = "apple",
            Pear = "pear",
            Quince = "quince",
        }
    }

    #[test]
    fn words_parse_back_and_anything_else_is_one_line_listing_them() {
        for fruit in Fruit::ALL {
            assert_eq!(fruit.name().parse::<Fruit>().unwrap(), *fruit);
        }
        assert_eq!(Fruit::default(), Fruit::Apple);
        assert_eq!(Fruit::Quince.index(), 2);
        assert_eq!(Fruit::NAMES, ["apple", "pear", "quince"]);
        let e = "plum".parse::<Fruit>().unwrap_err().to_string();
        assert_eq!(e, "unknown --fruit 'plum' (expected apple, pear or quince)");
        let long = "x".repeat(500);
        let e = long.parse::<Fruit>().unwrap_err().to_string();
        assert!(e.len() < 150, "{e}");
    }

    #[test]
    fn one_of_lists_words_as_a_sentence() {
        assert_eq!(one_of(&[]), "");
        assert_eq!(one_of(&["a"]), "a");
        assert_eq!(one_of(&["a", "b"]), "a or b");
        assert_eq!(one_of(&["a", "b", "c"]), "a, b or c");
    }
}
