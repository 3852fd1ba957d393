//! Statistics a method family reports beyond what every frame has (`tiled`'s rounds and work
//! counters, `convex`'s order): their type lives in the family's folder, a frame carries them as
//! [`FamilyStats`] without knowing it, and a caller reads them by type
//! ([`crate::FrameStats::family`]). In a frame's JSON they sit under their key, beside the
//! common fields.

use std::any::Any;
use std::sync::Arc;

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
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
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
