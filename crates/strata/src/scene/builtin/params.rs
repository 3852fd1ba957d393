//! `key=value&key=value` parameters of a `builtin:NAME?...` spec, with one-line errors that name
//! the scene, the key and what is wrong.

use std::str::FromStr;

use crate::error::{quoted, Error, Result};

#[derive(Debug)]
pub(crate) struct Params<'a> {
    /// `builtin:NAME`, for error messages.
    what: String,
    pairs: Vec<(&'a str, &'a str)>,
}

impl<'a> Params<'a> {
    /// Parses `query` (what follows `?`, possibly empty) and rejects keys not in `allowed` and
    /// repeated keys.
    pub(crate) fn parse(what: String, query: &'a str, allowed: &[&str]) -> Result<Self> {
        let mut pairs: Vec<(&str, &str)> = Vec::new();
        for piece in query.split('&').filter(|p| !p.is_empty()) {
            let Some((key, value)) = piece.split_once('=') else {
                return Err(Error::input(format!(
                    "{what}: parameter '{}' needs a value (key=value)",
                    quoted(piece)
                )));
            };
            let (key, value) = (key.trim(), value.trim());
            if !allowed.contains(&key) {
                let expected = if allowed.is_empty() {
                    "this scene takes no parameters".to_string()
                } else {
                    format!("expected {}", allowed.join(", "))
                };
                return Err(Error::input(format!(
                    "{what}: unknown parameter '{}' ({expected})",
                    quoted(key)
                )));
            }
            if pairs.iter().any(|(k, _)| *k == key) {
                return Err(Error::input(format!(
                    "{what}: parameter '{key}' is given twice"
                )));
            }
            pairs.push((key, value));
        }
        Ok(Params { what, pairs })
    }

    fn raw(&self, key: &str) -> Option<&'a str> {
        self.pairs.iter().find(|(k, _)| *k == key).map(|(_, v)| *v)
    }

    fn parsed<T: FromStr>(&self, key: &str, default: T, kind: &str) -> Result<T> {
        match self.raw(key) {
            None => Ok(default),
            Some(v) => v.parse().map_err(|_| {
                Error::input(format!(
                    "{}: {key}='{}' is not {kind}",
                    self.what,
                    quoted(v)
                ))
            }),
        }
    }

    /// An integer parameter within `lo..=hi`.
    pub(crate) fn int(&self, key: &str, default: u64, lo: u64, hi: u64) -> Result<u64> {
        let v = self.parsed(key, default, "a non-negative integer")?;
        if !(lo..=hi).contains(&v) {
            return Err(Error::input(format!(
                "{}: {key}={v} is out of range (expected {lo}..={hi})",
                self.what
            )));
        }
        Ok(v)
    }

    /// A finite number parameter within `lo..=hi`.
    pub(crate) fn float(&self, key: &str, default: f32, lo: f32, hi: f32) -> Result<f32> {
        let v: f32 = self.parsed(key, default, "a number")?;
        if !(v.is_finite() && v >= lo && v <= hi) {
            return Err(Error::input(format!(
                "{}: {key}={v} is out of range (expected {lo}..={hi})",
                self.what
            )));
        }
        Ok(v)
    }

    /// One of `options` (the first is the default).
    pub(crate) fn choice(&self, key: &str, options: &[&'static str]) -> Result<&'static str> {
        match self.raw(key) {
            None => Ok(options[0]),
            Some(v) => options.iter().copied().find(|o| *o == v).ok_or_else(|| {
                Error::input(format!(
                    "{}: {key}='{v}' is not one of {}",
                    self.what,
                    options.join(", ")
                ))
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_rejects() {
        let p = Params::parse("builtin:x".into(), "n=3&c=0.5&o=back", &["n", "c", "o"]).unwrap();
        assert_eq!(p.int("n", 1, 1, 10).unwrap(), 3);
        assert_eq!(p.float("c", 0.1, 0.0, 1.0).unwrap(), 0.5);
        assert_eq!(p.choice("o", &["front", "back"]).unwrap(), "back");
        let e = Params::parse("builtin:x".into(), "q=1", &["n"])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("builtin:x") && e.contains("unknown parameter 'q'"),
            "{e}"
        );
        let e = Params::parse("builtin:x".into(), "n", &["n"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("needs a value"), "{e}");
        let e = Params::parse("builtin:x".into(), "n=1&n=2", &["n"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("twice"), "{e}");
        let p = Params::parse("builtin:x".into(), "n=abc&c=2", &["n", "c"]).unwrap();
        let e = p.int("n", 1, 1, 10).unwrap_err().to_string();
        assert!(e.contains("n='abc'") && e.contains("integer"), "{e}");
        let e = p.float("c", 0.5, 0.0, 1.0).unwrap_err().to_string();
        assert!(e.contains("out of range"), "{e}");
        let e = p.choice("n", &["a", "b"]).unwrap_err().to_string();
        assert!(e.contains("not one of a, b"), "{e}");
        let p = Params::parse("builtin:x".into(), "c=nan", &["c"]).unwrap();
        assert!(p.float("c", 0.5, 0.0, 1.0).is_err());
    }
}
