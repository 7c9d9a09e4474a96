//! See-SPOT-Run's method names as presets: a rule (CCD, Eq. 8, or L2CD,
//! Eq. 9) and a set of extensions ([`crate::extension`]). The names are the
//! records', the command line's and Python's; the report's planned
//! comparisons of the extensions are generated from [`PRESETS`].
//!
//! A new method is one row here. A row's name never changes meaning once
//! records carry it.

use crate::explain::Method;
use crate::extension::{Extensions, Information};

/// One planned comparison of a preset: against `against`, asking `why`.
#[derive(Clone, Copy, Debug)]
pub struct Against {
    /// A preset's name, or `transporter`.
    pub against: &'static str,
    pub why: &'static str,
    /// Also asked on every embedding set the records hold (both runs on the
    /// set; against the TransporterNet, which has no embedding set, its own
    /// run).
    pub on_sets: bool,
}

const fn against(against: &'static str, why: &'static str) -> Against {
    Against {
        against,
        why,
        on_sets: true,
    }
}

const fn against_here(against: &'static str, why: &'static str) -> Against {
    Against {
        against,
        why,
        on_sets: false,
    }
}

/// One method of See-SPOT-Run.
#[derive(Debug)]
pub struct PresetDef {
    /// The record name (`ssr-ccd-replace`).
    pub name: &'static str,
    /// CCD or L2CD.
    pub rule: Method,
    /// The extensions, by [`crate::extension::REGISTRY`] name.
    pub extensions: &'static [&'static str],
    /// The method as the page and the trial's actor name it.
    pub title: &'static str,
    /// The method as the report names it.
    pub display: &'static str,
    /// The comparisons the report plans for it.
    pub compare: &'static [Against],
    /// On an embedding set, asked against the same preset on the SPOT-Q
    /// policies, with this phrase after "embedding set X against the SPOT-Q
    /// policies" (`None`: not asked).
    pub set_against_spot_q: Option<&'static str>,
}

/// Every preset, in the order runs are listed.
pub const PRESETS: &[PresetDef] = &[
    PresetDef {
        name: "ssr-ccd",
        rule: Method::SsrCcd,
        extensions: &[],
        title: "See-SPOT-Run CCD",
        display: "SSR CCD",
        compare: &[],
        set_against_spot_q: None,
    },
    PresetDef {
        name: "ssr-l2cd",
        rule: Method::SsrL2cd,
        extensions: &[],
        title: "See-SPOT-Run L2CD",
        display: "SSR L2CD",
        compare: &[],
        set_against_spot_q: None,
    },
    PresetDef {
        name: "ssr-ccd-loopbreak",
        rule: Method::SsrCcd,
        extensions: &["loop-break"],
        title: "See-SPOT-Run CCD + loop breaking (seespot's extension)",
        display: "Extension: SSR CCD + loop breaking",
        compare: &[against(
            "ssr-ccd",
            "seespot's extension against the faithful method",
        )],
        set_against_spot_q: None,
    },
    PresetDef {
        name: "ssr-ccd-noloops",
        rule: Method::SsrCcd,
        extensions: &["loop-break", "put-back-break"],
        title: "See-SPOT-Run CCD + loop and put-back breaking (seespot's extension)",
        display: "Extension: SSR CCD + loop and put-back breaking",
        compare: &[
            against_here(
                "ssr-ccd",
                "seespot's loop and put-back breaking against the faithful method",
            ),
            against(
                "ssr-ccd-loopbreak",
                "what put-back breaking adds to loop breaking",
            ),
            against_here(
                "transporter",
                "seespot's extension against the few-shot baseline trained on the test task's demonstrations",
            ),
        ],
        set_against_spot_q: Some("with both extensions"),
    },
    PresetDef {
        name: "ssr-ccd-guarded",
        rule: Method::SsrCcd,
        extensions: &["loop-break", "put-back-break", "reversal-guard"],
        title: "See-SPOT-Run CCD + loop and put-back breaking + reversal guard (seespot's extension)",
        display: "Extension: SSR CCD + loop and put-back breaking + reversal guard",
        compare: &[against(
            "ssr-ccd-noloops",
            "what the reversal guard adds to put-back breaking",
        )],
        set_against_spot_q: None,
    },
    PresetDef {
        name: "ssr-ccd-regrasp",
        rule: Method::SsrCcd,
        extensions: &["loop-break", "regrasp", "put-back-break", "reversal-guard"],
        title: "See-SPOT-Run CCD + loop and put-back breaking + reversal guard + regrasp (seespot's extension)",
        display: "Extension: SSR CCD + loop and put-back breaking + reversal guard + regrasp",
        compare: &[against(
            "ssr-ccd-guarded",
            "what regrasp adds to the reversal guard",
        )],
        set_against_spot_q: None,
    },
    PresetDef {
        name: "ssr-ccd-replace",
        rule: Method::SsrCcd,
        extensions: &["loop-break", "regrasp", "replace", "reversal-guard"],
        title: "See-SPOT-Run CCD + loop breaking + reversal guard + regrasp + replacing (seespot's extension)",
        display: "Extension: SSR CCD + loop breaking + reversal guard + regrasp + replacing",
        compare: &[
            against(
                "ssr-ccd-regrasp",
                "replacing in place of put-back breaking, with regrasp",
            ),
            against(
                "ssr-ccd",
                "seespot's extensions together (loop breaking, reversal guard, regrasp, replacing) against the faithful method",
            ),
            against_here(
                "ssr-ccd-loopbreak",
                "seespot's extensions together (loop breaking, reversal guard, regrasp, replacing) against loop breaking alone",
            ),
            against_here(
                "transporter",
                "seespot's extensions together (loop breaking, reversal guard, regrasp, replacing) against the few-shot baseline trained on the test task's demonstrations",
            ),
        ],
        set_against_spot_q: Some("with the extensions together"),
    },
    PresetDef {
        name: "ssr-ccd-unguarded",
        rule: Method::SsrCcd,
        extensions: &["loop-break", "regrasp", "replace"],
        title: "See-SPOT-Run CCD + loop breaking + regrasp + replacing (seespot's extension, no simulator state)",
        display: "Extension: SSR CCD + loop breaking + regrasp + replacing",
        compare: &[against(
            "ssr-ccd-replace",
            "what the reversal guard (simulator state) adds to loop breaking, regrasp and replacing",
        )],
        set_against_spot_q: None,
    },
    PresetDef {
        name: "ssr-ccd-built",
        rule: Method::SsrCcd,
        extensions: &["loop-break", "regrasp", "replace", "built-guard"],
        title: "See-SPOT-Run CCD + loop breaking + regrasp + replacing + built guard (seespot's extension, no simulator state)",
        display: "Extension: SSR CCD + loop breaking + regrasp + replacing + built guard",
        compare: &[
            against(
                "ssr-ccd-unguarded",
                "what the built guard (progress) adds to loop breaking, regrasp and replacing",
            ),
            against(
                "ssr-ccd-replace",
                "the built guard (progress) against the reversal guard (simulator state)",
            ),
            against(
                "ssr-ccd",
                "seespot's extensions without simulator state against the faithful method",
            ),
            against_here(
                "ssr-ccd-loopbreak",
                "seespot's extensions without simulator state against loop breaking alone",
            ),
            against_here(
                "transporter",
                "seespot's extensions without simulator state against the few-shot baseline trained on the test task's demonstrations",
            ),
        ],
        set_against_spot_q: Some("with the extensions without simulator state"),
    },
    PresetDef {
        name: "ssr-ccd-undo",
        rule: Method::SsrCcd,
        extensions: &["loop-break", "regrasp", "replace", "built-guard", "undo"],
        title: "See-SPOT-Run CCD + loop breaking + regrasp + replacing + built guard + undo (seespot's extension, no simulator state)",
        display: "Extension: SSR CCD + loop breaking + regrasp + replacing + built guard + undo",
        compare: &[
            against("ssr-ccd-built", "what undo adds to the built guard"),
            against(
                "ssr-ccd-replace",
                "the built guard and undo (progress) against the reversal guard (simulator state)",
            ),
            against(
                "ssr-ccd",
                "seespot's extensions with undo, without simulator state, against the faithful method",
            ),
            against_here(
                "transporter",
                "seespot's extensions with undo, without simulator state, against the few-shot baseline trained on the test task's demonstrations",
            ),
        ],
        set_against_spot_q: Some("with undo, without simulator state"),
    },
    PresetDef {
        name: "ssr-ccd-undo-wide",
        rule: Method::SsrCcd,
        extensions: &[
            "loop-break",
            "regrasp",
            "replace",
            "built-guard",
            "undo-wide",
        ],
        title: "See-SPOT-Run CCD + loop breaking + regrasp + replacing + built guard + undo within 3 cm (seespot's extension, no simulator state)",
        display: "Extension: SSR CCD + loop breaking + regrasp + replacing + built guard + undo (3 cm)",
        compare: &[
            against(
                "ssr-ccd-built",
                "what undo within 3 cm adds to the built guard",
            ),
            against(
                "ssr-ccd-replace",
                "the built guard and undo within 3 cm (progress) against the reversal guard (simulator state)",
            ),
            against(
                "ssr-ccd",
                "seespot's extensions with undo within 3 cm, without simulator state, against the faithful method",
            ),
            against_here(
                "ssr-ccd-loopbreak",
                "seespot's extensions with undo within 3 cm, without simulator state, against loop breaking alone",
            ),
            against_here(
                "transporter",
                "seespot's extensions with undo within 3 cm, without simulator state, against the few-shot baseline trained on the test task's demonstrations",
            ),
        ],
        set_against_spot_q: Some("with undo within 3 cm, without simulator state"),
    },
    PresetDef {
        name: "ssr-ccd-undo-wide-guard",
        rule: Method::SsrCcd,
        extensions: &[
            "loop-break",
            "regrasp",
            "replace",
            "built-guard-wide",
            "undo-wide",
        ],
        title: "See-SPOT-Run CCD + loop breaking + regrasp + replacing + built guard within 3.75 cm + undo within 3 cm (seespot's extension, no simulator state)",
        display: "Extension: SSR CCD + loop breaking + regrasp + replacing + built guard (3.75 cm) + undo (3 cm)",
        compare: &[
            against(
                "ssr-ccd-undo-wide",
                "what a built guard of three quarters of a block adds to one of half a block",
            ),
            against(
                "ssr-ccd-replace",
                "the wide built guard and undo (progress) against the reversal guard (simulator state)",
            ),
            against(
                "ssr-ccd",
                "seespot's extensions with the wide guard and undo, without simulator state, against the faithful method",
            ),
            against(
                "ssr-ccd-loopbreak",
                "seespot's extensions with the wide guard and undo, without simulator state, against loop breaking alone",
            ),
            against(
                "transporter",
                "seespot's extensions with the wide guard and undo, without simulator state, against the few-shot baseline trained on the test task's demonstrations",
            ),
        ],
        set_against_spot_q: Some("with the wide guard and undo, without simulator state"),
    },
];

/// A preset: an index into [`PRESETS`] (ordered as the table is).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Preset(u8);

impl Preset {
    pub const SSR_CCD: Self = Self(0);
    pub const SSR_L2CD: Self = Self(1);
    pub const LOOP_BREAK: Self = Self(2);
    pub const NO_LOOPS: Self = Self(3);
    pub const GUARDED: Self = Self(4);
    pub const REGRASP: Self = Self(5);
    pub const REPLACE: Self = Self(6);

    /// Every preset, in table order.
    pub fn all() -> impl Iterator<Item = Self> {
        (0..PRESETS.len()).map(|i| Self(i as u8))
    }

    /// The preset named `name`.
    pub fn named(name: &str) -> Option<Self> {
        Self::all().find(|p| p.name() == name)
    }

    pub fn def(self) -> &'static PresetDef {
        &PRESETS[self.0 as usize]
    }

    pub fn name(self) -> &'static str {
        self.def().name
    }

    pub fn rule(self) -> Method {
        self.def().rule
    }

    /// The preset's extensions (checked by the table's test).
    pub fn extensions(self) -> Extensions {
        Extensions::named(self.def().extensions).expect("PRESETS holds valid sets")
    }

    /// The most privileged information the method reads.
    pub fn information(self) -> Information {
        self.extensions().information()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_is_a_valid_set_with_a_unique_name_and_known_comparisons() {
        for (i, p) in PRESETS.iter().enumerate() {
            assert!(PRESETS[..i].iter().all(|q| q.name != p.name), "{}", p.name);
            Extensions::named(p.extensions).unwrap_or_else(|e| panic!("{}: {e}", p.name));
            for a in p.compare {
                assert!(
                    a.against == "transporter" || Preset::named(a.against).is_some(),
                    "{}: {}",
                    p.name,
                    a.against
                );
            }
        }
        for (p, name) in [
            (Preset::SSR_CCD, "ssr-ccd"),
            (Preset::SSR_L2CD, "ssr-l2cd"),
            (Preset::LOOP_BREAK, "ssr-ccd-loopbreak"),
            (Preset::NO_LOOPS, "ssr-ccd-noloops"),
            (Preset::GUARDED, "ssr-ccd-guarded"),
            (Preset::REGRASP, "ssr-ccd-regrasp"),
            (Preset::REPLACE, "ssr-ccd-replace"),
        ] {
            assert_eq!(p.name(), name);
        }
    }

    #[test]
    fn the_paper_methods_read_heightmaps_and_the_guarded_ones_the_simulator() {
        assert_eq!(Preset::SSR_CCD.information(), Information::Heightmaps);
        assert!(Preset::SSR_CCD.extensions().is_empty());
        assert_eq!(Preset::LOOP_BREAK.information(), Information::Heightmaps);
        assert_eq!(Preset::NO_LOOPS.information(), Information::Progress);
        assert_eq!(Preset::REPLACE.information(), Information::Simulator);
    }
}
