//! What a method family keeps of its own in a frame's values, without the frame knowing its type:
//! - its options ([`FamilyOption`], carried by [`crate::FrameOptions`] as [`FamilyOptions`]: the
//!   k-buffer family's `--tail`, peeling's `--layers`, the weighted family's `--weight`, …),
//!   declared, defaulted and range-checked in the family's folder and read by type
//!   (`frame.family::<KBufferOptions>()`);
//! - its statistics beyond what every frame has (`tiled`'s rounds and work counters, `convex`'s
//!   order): their type lives in the family's folder, a frame carries them as [`FamilyStats`], and
//!   a caller reads them by type ([`crate::FrameStats::family`]). In a frame's JSON they sit
//!   under their key, beside the common fields.

use std::any::{Any, TypeId};
use std::sync::Arc;

use crate::error::Result;

/// A family's options: the values its flags set (implemented in the family's folder). A frame
/// that was never given them holds their default.
pub trait FamilyOption: Any + Clone + PartialEq + Default + std::fmt::Debug + Send + Sync {
    /// The values that are wrong whatever the method: one line naming the flag.
    fn validate(&self) -> Result<()>;
}

/// What [`FamilyOptions`] needs of a [`FamilyOption`] as a trait object.
trait StoredOption: Any + std::fmt::Debug + Send + Sync {
    fn validate(&self) -> Result<()>;
    fn boxed(&self) -> Box<dyn StoredOption>;
    fn same(&self, other: &dyn StoredOption) -> bool;
    fn is_default(&self) -> bool;
    fn any(&self) -> &dyn Any;
    fn any_mut(&mut self) -> &mut dyn Any;
}

impl<T: FamilyOption> StoredOption for T {
    fn validate(&self) -> Result<()> {
        FamilyOption::validate(self)
    }
    fn boxed(&self) -> Box<dyn StoredOption> {
        Box::new(self.clone())
    }
    fn same(&self, other: &dyn StoredOption) -> bool {
        other.any().downcast_ref::<T>() == Some(self)
    }
    fn is_default(&self) -> bool {
        *self == T::default()
    }
    fn any(&self) -> &dyn Any {
        self
    }
    fn any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// Every family's options of a frame, one value per type; a type never set reads as its
/// default, and two sets are equal when every family's options are.
#[derive(Debug, Default)]
pub struct FamilyOptions(Vec<Box<dyn StoredOption>>);

impl FamilyOptions {
    fn find(&self, id: TypeId) -> Option<&dyn StoredOption> {
        self.0
            .iter()
            .map(|o| o.as_ref())
            .find(|o| o.any().type_id() == id)
    }

    /// The family's options (their default when never set).
    pub fn get<T: FamilyOption>(&self) -> T {
        self.find(TypeId::of::<T>())
            .and_then(|o| o.any().downcast_ref::<T>())
            .cloned()
            .unwrap_or_default()
    }

    /// The family's options to change (set to their default first when never set).
    pub fn get_mut<T: FamilyOption>(&mut self) -> &mut T {
        let at = match self.0.iter().position(|o| o.any().is::<T>()) {
            Some(at) => at,
            None => {
                self.0.push(Box::new(T::default()));
                self.0.len() - 1
            }
        };
        self.0[at]
            .any_mut()
            .downcast_mut()
            .expect("found by its type")
    }

    /// Sets the family's options.
    pub fn set<T: FamilyOption>(&mut self, value: T) {
        *self.get_mut::<T>() = value;
    }

    /// Each family's own check of its values.
    pub fn validate(&self) -> Result<()> {
        self.0.iter().try_for_each(|o| o.validate())
    }

    /// Whether every option of `self` is `other`'s or, where `other` has none, the default.
    fn within(&self, other: &FamilyOptions) -> bool {
        self.0.iter().all(|o| match other.find(o.any().type_id()) {
            Some(theirs) => o.same(theirs),
            None => o.is_default(),
        })
    }
}

impl Clone for FamilyOptions {
    fn clone(&self) -> Self {
        FamilyOptions(self.0.iter().map(|o| o.boxed()).collect())
    }
}

impl PartialEq for FamilyOptions {
    fn eq(&self, other: &FamilyOptions) -> bool {
        self.within(other) && other.within(self)
    }
}

/// A family's statistics of one frame (implemented in the family's folder).
pub trait FamilyStat: Any + std::fmt::Debug + Send + Sync {
    /// Their key in a frame's JSON (`"tiled"`, `"convex"`).
    fn key(&self) -> &'static str;

    /// Their JSON.
    #[cfg(feature = "serde")]
    fn to_json(&self) -> serde_json::Value;

    /// These and the next band's of the same picture together (a picture rendered in bands of
    /// rows); `None` keeps this band's.
    fn with_band(&self, _next: &FamilyStats) -> Option<FamilyStats> {
        None
    }

    /// Whether the frame kept what the method promised, as far as these statistics tell
    /// (`convex`: no pixel-pass found its order broken); feeds
    /// [`crate::methods::Descriptor::exactness`].
    fn kept_promise(&self) -> bool {
        true
    }

    /// What a render's summary says of them on the command line, one line (`None`: nothing
    /// worth a line).
    fn note(&self) -> Option<String> {
        None
    }
}

/// One family's statistics, shared cheaply between copies of a frame's statistics.
#[derive(Clone, Debug)]
pub struct FamilyStats(Arc<dyn FamilyStat>);

impl FamilyStats {
    /// Wraps a family's statistics.
    pub fn new(stats: impl FamilyStat) -> FamilyStats {
        FamilyStats(Arc::new(stats))
    }

    /// The statistics, when they are of type `T`.
    pub fn get<T: FamilyStat>(&self) -> Option<&T> {
        (self.0.as_ref() as &dyn Any).downcast_ref()
    }

    /// The statistics as their trait.
    pub fn stat(&self) -> &dyn FamilyStat {
        self.0.as_ref()
    }
}

/// Written as `{ key: statistics }`, which a frame's statistics flatten beside their own fields.
#[cfg(feature = "serde")]
impl serde::Serialize for FamilyStats {
    fn serialize<S: serde::Serializer>(
        &self,
        serializer: S,
    ) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = serializer.serialize_map(Some(1))?;
        map.serialize_entry(self.0.key(), &self.0.to_json())?;
        map.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq)]
    struct Rounds(u32);

    impl FamilyStat for Rounds {
        fn key(&self) -> &'static str {
            "rounds"
        }
        #[cfg(feature = "serde")]
        fn to_json(&self) -> serde_json::Value {
            serde_json::json!({ "rounds": self.0 })
        }
    }

    #[derive(Debug)]
    struct Other;

    impl FamilyStat for Other {
        fn key(&self) -> &'static str {
            "other"
        }
        #[cfg(feature = "serde")]
        fn to_json(&self) -> serde_json::Value {
            serde_json::Value::Null
        }
    }

    #[derive(Clone, Debug, Default, PartialEq)]
    struct Passes(u32);

    impl FamilyOption for Passes {
        fn validate(&self) -> Result<()> {
            match self.0 {
                0..=8 => Ok(()),
                n => Err(crate::Error::input(format!("--passes {n} is over 8"))),
            }
        }
    }

    #[derive(Clone, Debug, Default, PartialEq)]
    struct Shape(&'static str);

    impl FamilyOption for Shape {
        fn validate(&self) -> Result<()> {
            Ok(())
        }
    }

    #[test]
    fn family_options_read_as_set_or_default_by_their_own_type() {
        let mut options = FamilyOptions::default();
        assert_eq!(options.get::<Passes>(), Passes(0));
        options.get_mut::<Passes>().0 = 3;
        options.set(Shape("round"));
        assert_eq!(options.get::<Passes>(), Passes(3));
        assert_eq!(options.get::<Shape>(), Shape("round"));
        let copy = options.clone();
        options.set(Passes(4));
        assert_eq!(copy.get::<Passes>(), Passes(3), "a clone is its own");
        assert_eq!(options.0.len(), 2, "one value per type");
    }

    #[test]
    fn family_options_equal_when_each_familys_do_unset_being_default() {
        let mut set_to_default = FamilyOptions::default();
        set_to_default.set(Passes(0));
        assert_eq!(set_to_default, FamilyOptions::default());
        assert_eq!(FamilyOptions::default(), set_to_default);
        let mut three = FamilyOptions::default();
        three.set(Passes(3));
        assert_ne!(three, FamilyOptions::default());
        assert_ne!(FamilyOptions::default(), three);
        let mut shaped = three.clone();
        shaped.set(Shape("round"));
        assert_ne!(three, shaped);
        shaped.set(Shape(""));
        assert_eq!(three, shaped);
    }

    #[test]
    fn family_options_are_checked_by_their_family() {
        let mut options = FamilyOptions::default();
        options.set(Shape("any"));
        assert!(options.validate().is_ok());
        options.set(Passes(9));
        let e = options.validate().unwrap_err().to_string();
        assert!(e.contains("--passes 9"), "{e}");
    }

    #[test]
    fn family_statistics_are_read_back_by_their_own_type_only() {
        let stats = FamilyStats::new(Rounds(3));
        assert_eq!(stats.get::<Rounds>(), Some(&Rounds(3)));
        assert!(stats.get::<Other>().is_none());
        assert_eq!(stats.stat().key(), "rounds");
        assert!(stats.stat().kept_promise());
    }

    #[cfg(feature = "serde")]
    #[test]
    fn family_statistics_flatten_under_their_key() {
        #[derive(serde::Serialize)]
        struct Frame {
            frame: u64,
            #[serde(flatten)]
            family: Option<FamilyStats>,
        }
        let with = Frame {
            frame: 1,
            family: Some(FamilyStats::new(Rounds(3))),
        };
        let without = Frame {
            frame: 2,
            family: None,
        };
        assert_eq!(
            serde_json::to_string(&with).unwrap(),
            r#"{"frame":1,"rounds":{"rounds":3}}"#
        );
        assert_eq!(serde_json::to_string(&without).unwrap(), r#"{"frame":2}"#);
    }
}
