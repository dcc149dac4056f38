//! The registry of friction-law families: one `mod` line and one entry
//! per family, simplest first. The order is the order of `--law auto`'s
//! candidates and of every list of families.

#[path = "coulomb.rs"]
pub(super) mod coulomb;
#[path = "decreasing.rs"]
pub(super) mod decreasing;
#[path = "exponential.rs"]
mod exponential;
#[path = "static_dynamic.rs"]
pub(super) mod static_dynamic;
#[path = "stribeck.rs"]
pub(super) mod stribeck;

use super::LawKind;

/// Every family, simplest first.
pub(super) static REGISTRY: &[LawKind] = &[
    LawKind::Coulomb,
    LawKind::Decreasing,
    LawKind::StaticDynamic,
    LawKind::Stribeck,
    LawKind(&exponential::Exponential),
];
