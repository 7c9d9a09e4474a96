//! Correspond's options, in one typed form: [`CorrespondOptions`] holds a
//! formulation with only its own options; [`CorrespondSettings`] is the same
//! configuration as records' settings, the command line and Python spell it
//! (flat, every option named by its key), and its conversion into
//! [`CorrespondOptions`] holds the rules (which option belongs to which
//! formulation) once. The options' names come from one derive (serde for
//! records, strum for the names the command line and errors use).

use serde::{Deserialize, Serialize};

use super::CUnit;

/// A named choice of Correspond, with its derives: serde's names for
/// records, strum's for the command line and errors (the same lowercase
/// words), and the reference's choice as its `Default`.
macro_rules! choice {
    ($(#[$meta:meta])* pub enum $name:ident { $($body:tt)* }) => {
        $(#[$meta])*
        #[derive(
            Clone,
            Copy,
            Debug,
            Default,
            PartialEq,
            Eq,
            Serialize,
            Deserialize,
            strum::IntoStaticStr,
            strum::VariantArray,
        )]
        #[serde(rename_all = "lowercase")]
        #[strum(serialize_all = "lowercase")]
        pub enum $name { $($body)* }
    };
}

seespot_sim::named_choice!(Correspondence, "correspondence");
seespot_sim::named_choice!(Rematch, "rematch");
seespot_sim::named_choice!(Smoothing, "smoothing");
seespot_sim::named_choice!(DemoFeatures, "demo features");

choice! {
    /// Which formulation of Correspond SSR uses.
    pub enum Correspondence {
        /// The reference code's choices ([`mod@super::reference`]): test-time masks per task,
        /// squared distances smoothed at 6 mm, the rematch unmasked in a 3 cm window
        /// at the demo's rotation, C in squared 2 mm pixels, ties to the first pair.
        /// The faithful default, named `ssr-ccd` / `ssr-l2cd` in records.
        #[default]
        Reference,
        /// seespot's first formulation, kept for comparison (records `ssr-ccd-plain`,
        /// `ssr-l2cd-plain`): the training-time common-sense masks, unsquared
        /// distances (smoothed only with `smooth_sigma`), the rematch over the whole
        /// masked demo rotation plane, C in pixels, ties broken by the other distance.
        Plain,
    }
}

/// Options of the Correspond step: each formulation with only its own
/// options, so a combination that means nothing (a smoothing sigma with the
/// reference's Correspond, a rematch area with the plain one) is not a value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CorrespondOptions {
    /// The reference code's Correspond ([`mod@super::reference`]), the faithful
    /// default; each option's default is the reference's choice, the others
    /// are named departures.
    Reference {
        /// What the rematch reads at the demo's actions outside its test-time mask.
        demo_features: DemoFeatures,
        /// How the distance maps are smoothed.
        smoothing: Smoothing,
        /// Where the rematch searches and what C measures.
        rematch: Rematch,
    },
    /// seespot's first formulation (the scan functions of this module).
    Plain {
        /// Gaussian smoothing of each per-rotation `H x W` distance map before
        /// the argmin, sigma in pixels (the reference code used 3 px). `None` = off.
        ///
        /// Cost: smoothing needs the full distance maps instead of a running minimum,
        /// plus a separable normalized convolution of `2 * (2 * ceil(3 sigma) + 1)`
        /// taps per pixel for each query; at 16 x 224 x 224 with 2 queries and
        /// sigma 3 that adds roughly the time of one extra scan (see
        /// [`crate::bench::bench_correspond`], `correspond_smoothed_ms`).
        smooth_sigma: Option<f32>,
    },
}

impl Default for CorrespondOptions {
    /// The reference's Correspond with the reference's choices.
    fn default() -> Self {
        Self::of_mode(Correspondence::Reference)
    }
}

impl CorrespondOptions {
    /// The unit of the C these options compute.
    pub fn c_unit(&self) -> CUnit {
        match self {
            Self::Reference { .. } => CUnit::SquaredReferencePixels,
            Self::Plain { .. } => CUnit::Pixels,
        }
    }

    /// `mode` with its default options (the reference's choices; no smoothing
    /// for the plain scan).
    pub fn of_mode(mode: Correspondence) -> Self {
        match mode {
            Correspondence::Reference => Self::Reference {
                demo_features: DemoFeatures::default(),
                smoothing: Smoothing::default(),
                rematch: Rematch::default(),
            },
            Correspondence::Plain => Self::Plain { smooth_sigma: None },
        }
    }

    /// Which formulation these are options of.
    pub fn mode(&self) -> Correspondence {
        match self {
            Self::Reference { .. } => Correspondence::Reference,
            Self::Plain { .. } => Correspondence::Plain,
        }
    }

    /// The plain scan's smoothing sigma, pixels (`None` for the reference's
    /// Correspond, which smooths at 6 mm by [`Smoothing`]).
    pub fn smooth_sigma(&self) -> Option<f32> {
        match self {
            Self::Plain { smooth_sigma } => *smooth_sigma,
            Self::Reference { .. } => None,
        }
    }
}

choice! {
    /// Where the reference rematch searches, and what C measures.
    ///
    /// The reference's `compute_cc_dist` has both: its default (and the paper's
    /// Eq. 7) searches a window around the demonstrated action and measures C
    /// from it; the authors' trial runner (`main.py`) called it with
    /// `neighborhood_match=False`, which searches the whole demo plane and
    /// measures C from the live match F. The default follows the paper.
    pub enum Rematch {
        /// Eq. 7 as the paper writes it (the faithful default): the rematch in
        /// the window of +/- 3 cm around the demonstrated pixel at the demo
        /// action's rotation; C is the squared pixel distance from the
        /// demonstrated action to the rematch.
        #[default]
        Window,
        /// The reference trial runner's pair (records `<method>-global-rematch`):
        /// the rematch over the whole demo plane at the demo action's rotation
        /// (smoothed with wrap-around edges); C is the squared pixel distance
        /// from the live match F to the rematch.
        Global,
    }
}

choice! {
    /// How the reference Correspond smooths its distance maps.
    pub enum Smoothing {
        /// As the reference did ([`mod@super::reference`]): masked actions take part as
        /// zero embeddings, scipy's kernel and edges, the rematch window cut out
        /// and wrapped (the faithful default).
        #[default]
        Reference,
        /// seespot's earlier smoothing, a departure kept for comparison (records
        /// `<method>-normalized`): masked actions left out of their neighbours'
        /// averages (normalized convolution, radius 3 sigma), and the rematch on
        /// the demo's real embeddings, its whole plane smoothed before the
        /// window's argmin.
        Normalized,
    }
}

choice! {
    /// What the reference rematch reads at demo actions outside the demo's
    /// test-time mask.
    pub enum DemoFeatures {
        /// Zero embeddings, as the reference's masked features were (the
        /// faithful default).
        #[default]
        Zeroed,
        /// The actions' real embeddings (a departure, recorded as
        /// `<method>-demo-real`): a demonstrated action outside its own mask
        /// can still be returned to.
        Real,
    }
}

/// Correspond's options as records' settings, `seespot eval`'s flags and
/// Python name them: the formulation and each option by its key, an option
/// left out taking its default. `smoothing` is written for SSR's runs with
/// the reference Correspond (records made before SSR smoothed as the
/// reference did have none), `demo_features` and `rematch` only where they
/// depart from the reference's; the runs of other methods write
/// `correspond` and `smooth_sigma` alone ([`CorrespondSettings::unused`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CorrespondSettings {
    /// The formulation (records always name it; the reference's when left out).
    #[serde(default)]
    pub correspond: Correspondence,
    /// The plain scan's smoothing, pixels.
    pub smooth_sigma: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub smoothing: Option<Smoothing>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub demo_features: Option<DemoFeatures>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rematch: Option<Rematch>,
}

/// An option given to the formulation it does not belong to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("`{setting}` applies to correspond {belongs} only, not {given}")]
pub struct CorrespondSettingsError {
    /// The option's key (`smoothing`, `smooth_sigma`, ...).
    pub setting: &'static str,
    pub belongs: &'static str,
    pub given: &'static str,
}

impl CorrespondSettings {
    /// Every key the settings have (a reader that cannot refuse unknown
    /// keys by serde, such as Python's dictionaries, checks against these).
    pub const KEYS: [&'static str; 5] = [
        "correspond",
        "smooth_sigma",
        "smoothing",
        "demo_features",
        "rematch",
    ];

    /// The settings of a run whose method does not correspond (no SSR).
    pub fn unused() -> Self {
        Self::default()
    }
}

impl From<CorrespondOptions> for CorrespondSettings {
    fn from(o: CorrespondOptions) -> Self {
        match o {
            CorrespondOptions::Plain { smooth_sigma } => Self {
                correspond: Correspondence::Plain,
                smooth_sigma,
                ..Self::default()
            },
            CorrespondOptions::Reference {
                demo_features,
                smoothing,
                rematch,
            } => Self {
                correspond: Correspondence::Reference,
                smooth_sigma: None,
                smoothing: Some(smoothing),
                demo_features: (demo_features != DemoFeatures::default()).then_some(demo_features),
                rematch: (rematch != Rematch::default()).then_some(rematch),
            },
        }
    }
}

impl TryFrom<CorrespondSettings> for CorrespondOptions {
    type Error = CorrespondSettingsError;

    /// The options the settings name; an option of the other formulation is
    /// refused, naming it.
    fn try_from(s: CorrespondSettings) -> Result<Self, Self::Error> {
        let wrong = |setting, belongs: Correspondence| CorrespondSettingsError {
            setting,
            belongs: belongs.as_str(),
            given: s.correspond.as_str(),
        };
        match s.correspond {
            Correspondence::Plain => {
                let reference_only = [
                    ("smoothing", s.smoothing.is_some()),
                    ("demo_features", s.demo_features.is_some()),
                    ("rematch", s.rematch.is_some()),
                ];
                if let Some((setting, _)) = reference_only.iter().find(|(_, given)| *given) {
                    return Err(wrong(setting, Correspondence::Reference));
                }
                Ok(Self::Plain {
                    smooth_sigma: s.smooth_sigma,
                })
            }
            Correspondence::Reference => {
                if s.smooth_sigma.is_some() {
                    return Err(wrong("smooth_sigma", Correspondence::Plain));
                }
                Ok(Self::Reference {
                    demo_features: s.demo_features.unwrap_or_default(),
                    smoothing: s.smoothing.unwrap_or_default(),
                    rematch: s.rematch.unwrap_or_default(),
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_come_from_the_derive_and_bad_ones_are_named() {
        assert_eq!(Rematch::Global.as_str(), "global");
        assert_eq!("real".parse::<DemoFeatures>(), Ok(DemoFeatures::Real));
        let e = "wide".parse::<Rematch>().expect_err("unknown");
        assert_eq!(e, "unknown rematch 'wide' (expected window or global)");
        assert_eq!(
            serde_json::to_string(&Smoothing::Normalized).expect("json"),
            "\"normalized\""
        );
    }

    /// Every option round-trips through its settings, which keep the
    /// records' keys; an option of the other formulation is refused.
    #[test]
    fn settings_round_trip_and_hold_the_rules() {
        let all = [
            CorrespondOptions::default(),
            CorrespondOptions::Plain { smooth_sigma: None },
            CorrespondOptions::Plain {
                smooth_sigma: Some(3.0),
            },
            CorrespondOptions::Reference {
                demo_features: DemoFeatures::Real,
                smoothing: Smoothing::Normalized,
                rematch: Rematch::Global,
            },
        ];
        for o in all {
            let s = CorrespondSettings::from(o);
            let json = serde_json::to_string(&s).expect("json");
            let back: CorrespondSettings = serde_json::from_str(&json).expect("read");
            assert_eq!(CorrespondOptions::try_from(back), Ok(o), "{json}");
        }
        assert_eq!(
            serde_json::to_string(&CorrespondSettings::from(CorrespondOptions::default()))
                .expect("json"),
            r#"{"correspond":"reference","smooth_sigma":null,"smoothing":"reference"}"#
        );
        assert_eq!(
            serde_json::to_string(&CorrespondSettings::unused()).expect("json"),
            r#"{"correspond":"reference","smooth_sigma":null}"#
        );
        let bad: CorrespondSettings = serde_json::from_str(
            r#"{"correspond":"plain","smooth_sigma":null,"rematch":"global"}"#,
        )
        .expect("read");
        let e = CorrespondOptions::try_from(bad).expect_err("refused");
        assert_eq!(
            e.to_string(),
            "`rematch` applies to correspond reference only, not plain"
        );
        let bad = CorrespondSettings {
            smooth_sigma: Some(2.0),
            ..CorrespondSettings::default()
        };
        let e = CorrespondOptions::try_from(bad).expect_err("refused");
        assert_eq!(e.setting, "smooth_sigma");
        assert!(
            serde_json::from_str::<CorrespondSettings>(
                r#"{"correspond":"fancy","smooth_sigma":null}"#
            )
            .is_err()
        );
        // KEYS names every key, in order.
        let full = CorrespondSettings {
            smooth_sigma: Some(1.0),
            smoothing: Some(Smoothing::Reference),
            demo_features: Some(DemoFeatures::Real),
            rematch: Some(Rematch::Global),
            ..CorrespondSettings::default()
        };
        let v = serde_json::to_value(full).expect("json");
        let keys: Vec<&str> = v
            .as_object()
            .expect("object")
            .keys()
            .map(String::as_str)
            .collect();
        let mut want = CorrespondSettings::KEYS.to_vec();
        let mut got = keys.clone();
        want.sort_unstable();
        got.sort_unstable();
        assert_eq!(got, want);
    }
}
