//! One file per command of `strata` (bench, report and view have folders or files of their own).

pub mod compare;
pub mod convex;
pub mod export;
pub mod histogram;
pub mod info;
pub mod methods;
pub mod reference;
pub mod render;
