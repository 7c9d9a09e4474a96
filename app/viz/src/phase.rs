//! The phases of one SSR decision, as the debugger steps through them (paper
//! Sec. 4.2: Embed, then Correspond as Match and Verify, then Act).

use serde::Serialize;

/// One phase of an SSR decision.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    PartialOrd,
    Ord,
    Serialize,
    strum::IntoStaticStr,
    strum::VariantArray,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case")]
pub enum Phase {
    Embed,
    Match,
    Verify,
    Act,
}

impl Phase {
    pub const ALL: [Phase; 4] = [Phase::Embed, Phase::Match, Phase::Verify, Phase::Act];
}

seespot_sim::named_choice!(Phase, "phase");
