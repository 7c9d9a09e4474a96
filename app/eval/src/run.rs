//! The identity of an evaluation run: [`RunSpec`], what decides (the method
//! and, for See-SPOT-Run, how its correspondence departs from the reference
//! code's), whether it was finetuned on the demonstrations and whether it saw
//! sensor noise. Its [`Display`](std::fmt::Display) is the one record name
//! (`ssr-ccd`, `ssr-l2cd-plain`, `good-robot-finetuned`, `ssr-ccd-noisy`,
//! ...), the name of the records folder, and [`FromStr`] reads it back; the
//! report, the review, replays and the Python package take a run's meaning
//! from the spec, never from pieces of its name.
//!
//! Invalid combinations are not values: the fields are private, and only SSR
//! carries a correspondence variant, only SSR, SPOT-Q and TransporterNet can
//! be finetuned. [`RunSpec::all`] lists every valid spec, and a name is read
//! back by finding the spec that writes it, so the two directions cannot
//! drift apart.

use std::collections::HashMap;
use std::fmt;
use std::str::FromStr;
use std::sync::OnceLock;

use seespot_policy::finetune::FinetuneProcedure;
use seespot_ssr::correspond::{CUnit, CorrespondOptions, DemoFeatures, Rematch, Smoothing};
use seespot_ssr::extension::Information;
use seespot_ssr::preset::Preset;

/// A method of the evaluation table; its name (`ssr-ccd`, ...) is the
/// records' and the command line's. See-SPOT-Run's methods are the presets
/// of [`seespot_ssr::preset::PRESETS`] (the paper's two rules and seespot's
/// labelled extensions); the associated constants name the ones code asks
/// for by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum EvalMethod {
    /// See-SPOT-Run as a preset names it.
    Ssr(Preset),
    /// The test task's own SPOT-Q policy, greedy: the ceiling row.
    SpotQ,
    /// The scripted oracle.
    Oracle,
    /// Uniform random actions under the common-sense masks.
    Random,
    /// The paper's few-shot baseline: a TransporterNet trained by imitation on
    /// the test task's two demonstrations (`models/transporter/<task>`); with
    /// finetuning steps, another task's TransporterNet finetuned on them.
    Transporter,
}

#[allow(non_upper_case_globals)]
impl EvalMethod {
    /// SSR acting on the smallest cycle consistency distance (Eq. 8).
    pub const SsrCcd: Self = Self::Ssr(Preset::SSR_CCD);
    /// SSR acting on the smallest embedding distance (Eq. 9).
    pub const SsrL2cd: Self = Self::Ssr(Preset::SSR_L2CD);
    /// seespot's extension, not the paper's: loop breaking.
    pub const SsrCcdLoopBreak: Self = Self::Ssr(Preset::LOOP_BREAK);
    /// seespot's extension: loop and put-back breaking.
    pub const SsrCcdNoLoops: Self = Self::Ssr(Preset::NO_LOOPS);
    /// seespot's extension: loop and put-back breaking, reversal guard.
    pub const SsrCcdGuarded: Self = Self::Ssr(Preset::GUARDED);
    /// seespot's extension: the reversal guard's method and regrasp.
    pub const SsrCcdRegrasp: Self = Self::Ssr(Preset::REGRASP);
    /// seespot's extension: loop breaking, regrasp, replacing, reversal guard.
    pub const SsrCcdReplace: Self = Self::Ssr(Preset::REPLACE);

    /// Every method: SSR's presets in table order, then the others.
    pub fn all() -> &'static [EvalMethod] {
        static ALL: OnceLock<Vec<EvalMethod>> = OnceLock::new();
        ALL.get_or_init(|| {
            Preset::all()
                .map(Self::Ssr)
                .chain([Self::SpotQ, Self::Oracle, Self::Random, Self::Transporter])
                .collect()
        })
    }

    /// The method's name, as records and the command line spell it.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Ssr(p) => p.name(),
            Self::SpotQ => "spot-q",
            Self::Oracle => "oracle",
            Self::Random => "random",
            Self::Transporter => "transporter",
        }
    }

    /// The method named `s`, if any.
    pub fn parse(s: &str) -> Option<Self> {
        s.parse().ok()
    }

    /// How See-SPOT-Run runs as this method with `correspond`: its
    /// preset's rule and extensions. Methods that are not SSR get the
    /// paper's SSR CCD.
    pub fn ssr_config(self, correspond: CorrespondOptions) -> seespot_ssr::SsrConfig {
        let preset = match self {
            Self::Ssr(p) => p,
            _ => Preset::SSR_CCD,
        };
        seespot_ssr::SsrConfig::preset(preset, correspond)
    }

    /// Whether the method is See-SPOT-Run (faithful or extended).
    pub fn is_ssr(self) -> bool {
        matches!(self, Self::Ssr(_))
    }

    /// The most privileged information the method reads to act: SSR's
    /// presets by their extensions; SPOT-Q, the TransporterNet and random
    /// actions read heightmaps; the oracle reads the simulator.
    pub fn information(self) -> Information {
        match self {
            Self::Ssr(p) => p.information(),
            Self::Oracle => Information::Simulator,
            Self::SpotQ | Self::Random | Self::Transporter => Information::Heightmaps,
        }
    }

    /// Whether the method runs SPOT-Q policies' networks (SSR embeds with
    /// them; SPOT-Q acts on its own task's Q maps).
    pub fn runs_spot_q_nets(self) -> bool {
        self.is_ssr() || self == Self::SpotQ
    }
}

/// The most privileged information run `name` reads to act (`heightmaps`,
/// `progress`, `simulator`), or `—` for a name that is no run's.
pub fn reads(name: &str) -> &'static str {
    name.parse::<RunSpec>()
        .map_or("—", |s| s.information().as_str())
}

impl FromStr for EvalMethod {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        seespot_sim::bounds::parse_named(s, Self::all(), Self::as_str, "method")
    }
}

/// How SSR's correspondence departs from the reference code's Correspond, as
/// far as it makes a run different (settings that do not, such as the plain
/// scan's smoothing sigma, are in the records' provenance instead).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CorrespondName {
    /// The reference code's Correspond with each of seespot's departures on
    /// or off: `-normalized` (`--smoothing normalized`), `-demo-real`
    /// (`--demo-features real`), `-global-rematch` (`--rematch global`).
    Reference {
        normalized: bool,
        demo_real: bool,
        global_rematch: bool,
    },
    /// The plain scan (`--correspond plain`): `-plain`.
    Plain,
}

impl CorrespondName {
    /// The reference code's Correspond, no departure: no suffix.
    pub const REFERENCE: Self = Self::Reference {
        normalized: false,
        demo_real: false,
        global_rematch: false,
    };

    /// The name of a set of Correspond options.
    pub fn of(options: &CorrespondOptions) -> Self {
        match *options {
            CorrespondOptions::Plain { .. } => Self::Plain,
            CorrespondOptions::Reference {
                demo_features,
                smoothing,
                rematch,
            } => Self::Reference {
                normalized: smoothing == Smoothing::Normalized,
                demo_real: demo_features == DemoFeatures::Real,
                global_rematch: rematch == Rematch::Global,
            },
        }
    }

    /// Every variant: the plain scan and the eight combinations of departures.
    pub fn all() -> impl Iterator<Item = Self> {
        (0..8u8)
            .map(|bits| Self::Reference {
                normalized: bits & 1 != 0,
                demo_real: bits & 2 != 0,
                global_rematch: bits & 4 != 0,
            })
            .chain([Self::Plain])
    }

    /// The record-name suffix, in a fixed order so every combination has its
    /// own name.
    fn suffix(self) -> String {
        match self {
            Self::Plain => "-plain".into(),
            Self::Reference {
                normalized,
                demo_real,
                global_rematch,
            } => [
                (normalized, "-normalized"),
                (demo_real, "-demo-real"),
                (global_rematch, "-global-rematch"),
            ]
            .into_iter()
            .filter(|(on, _)| *on)
            .map(|(_, s)| s)
            .collect(),
        }
    }

    /// The display suffix (`, plain correspondence`, ...).
    fn display_suffix(self) -> String {
        match self {
            Self::Plain => ", plain correspondence".into(),
            Self::Reference {
                normalized,
                demo_real,
                global_rematch,
            } => [
                (normalized, ", normalized smoothing"),
                (demo_real, ", real demo features"),
                (global_rematch, ", the reference runner's global rematch"),
            ]
            .into_iter()
            .filter(|(on, _)| *on)
            .map(|(_, s)| s)
            .collect(),
        }
    }
}

/// What a run trained on its test task, for the report's train steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TaskTraining {
    /// Nothing: SSR, the oracle, random actions.
    Nothing,
    /// The test task's own SPOT-Q policy (its recorded training steps).
    OwnSpotQ,
    /// The test task's own TransporterNet (its recorded iterations).
    OwnTransporter,
    /// Finetuning on the demonstrations: `factor` x the run's finetune steps
    /// (SSR: three policies; "Good Robot": one policy, or with the Adam
    /// variant one policy for three times the steps; TransporterNet: 1).
    Finetuning { factor: u64 },
}

/// The identity of an evaluation run (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RunSpec {
    method: EvalMethod,
    correspond: CorrespondName,
    /// How the run was finetuned on the demonstrations, if it was (the
    /// TransporterNet has one finetuning, named `Reference`).
    finetuned: Option<FinetuneProcedure>,
    noisy: bool,
    /// The embedding set SSR ran on, when not the SPOT-Q policies of
    /// `models/` (its [`seespot_ssr::layout::Embeddings::label`]).
    embeddings: Option<EmbeddingLabel>,
}

/// An embedding set's name in a run's name (`ssr-ccd@raw-patches`): lower
/// case letters, digits, `-` and `+`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct EmbeddingLabel(&'static str);

impl EmbeddingLabel {
    /// The label `s`, or why it is not one.
    pub fn new(s: &str) -> Result<Self, String> {
        use std::collections::HashSet;
        use std::sync::Mutex;
        let ok = !s.is_empty()
            && s.len() <= 120
            && s.chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-' || c == '+');
        if !ok {
            return Err(format!(
                "`{s}` is not an embedding set's name (1 to 120 of a-z, 0-9, `-` and `+`)"
            ));
        }
        // Labels are few (one per embedding set a process meets); each is
        // kept once for the process's life, so a spec stays `Copy`.
        static LABELS: OnceLock<Mutex<HashSet<&'static str>>> = OnceLock::new();
        let mut labels = LABELS
            .get_or_init(Default::default)
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let label = match labels.get(s) {
            Some(l) => l,
            None => {
                let l: &'static str = Box::leak(s.to_owned().into_boxed_str());
                labels.insert(l);
                l
            }
        };
        Ok(Self(label))
    }

    pub fn as_str(&self) -> &'static str {
        self.0
    }
}

impl RunSpec {
    /// `method` as the paper runs it: the reference Correspond, no
    /// finetuning, no sensor noise.
    pub const fn new(method: EvalMethod) -> Self {
        Self {
            method,
            correspond: CorrespondName::REFERENCE,
            finetuned: None,
            noisy: false,
            embeddings: None,
        }
    }

    /// This run on the embedding set `label`; an error for the methods that
    /// run no network of the set (SSR embeds with it, SPOT-Q acts on the Q
    /// outputs of its own task's file) and for finetuned runs, which
    /// finetune seespot's own weights.
    pub fn with_embeddings(self, label: EmbeddingLabel) -> Result<Self, String> {
        if !self.method.is_ssr() && self.method != EvalMethod::SpotQ {
            return Err(format!(
                "{} runs no embedding set; --embeddings applies to SSR's methods and to SPOT-Q \
                 (a folder of <task>.onnx files with Q outputs)",
                self.method.as_str()
            ));
        }
        if self.is_finetuned() {
            return Err(
                "finetuning trains seespot's own SPOT-Q weights; an embedding set is used as it is"
                    .to_owned(),
            );
        }
        Ok(Self {
            embeddings: Some(label),
            ..self
        })
    }

    /// The embedding set's name, if the run used one.
    pub fn embeddings(&self) -> Option<EmbeddingLabel> {
        self.embeddings
    }

    /// This run with SSR's correspondence `c`; for other methods, which have
    /// no correspondence, an error.
    pub fn with_correspond(self, c: CorrespondName) -> Result<Self, String> {
        if !self.method.is_ssr() && c != CorrespondName::REFERENCE {
            return Err(format!(
                "{} has no correspondence to vary",
                self.method.as_str()
            ));
        }
        Ok(Self {
            correspond: c,
            ..self
        })
    }

    /// This run finetuned on the demonstrations as the reference finetuned;
    /// an error for the oracle and random actions, which have no policy to
    /// finetune.
    pub fn finetuned(self) -> Result<Self, String> {
        self.finetuned_by(FinetuneProcedure::Reference)
    }

    /// This run finetuned by `procedure`; an error for the oracle and random
    /// actions, and for the TransporterNet with another procedure than its own.
    pub fn finetuned_by(self, procedure: FinetuneProcedure) -> Result<Self, String> {
        match self.method {
            EvalMethod::Oracle | EvalMethod::Random => Err(format!(
                "{} has no policy to finetune",
                self.method.as_str()
            )),
            EvalMethod::Transporter if procedure != FinetuneProcedure::Reference => Err(
                "the TransporterNet has one finetuning procedure; --finetune-procedure applies to SPOT-Q policies"
                    .to_owned(),
            ),
            _ => Ok(Self {
                finetuned: Some(procedure),
                ..self
            }),
        }
    }

    /// This run under sensor noise.
    pub const fn noisy(self) -> Self {
        Self {
            noisy: true,
            ..self
        }
    }

    /// The spec of a run of `method` with these settings (what
    /// [`crate::runner::EvalConfig::spec`] gives): the correspondence counts
    /// for SSR alone, and finetuning for the methods that have a policy.
    pub fn of_parts(
        method: EvalMethod,
        correspond: &CorrespondOptions,
        finetune_steps: usize,
        procedure: FinetuneProcedure,
        noisy: bool,
    ) -> Self {
        Self {
            method,
            correspond: if method.is_ssr() {
                CorrespondName::of(correspond)
            } else {
                CorrespondName::REFERENCE
            },
            finetuned: (finetune_steps > 0
                && !matches!(method, EvalMethod::Oracle | EvalMethod::Random))
            .then_some(if method == EvalMethod::Transporter {
                FinetuneProcedure::Reference
            } else {
                procedure
            }),
            noisy,
            embeddings: None,
        }
    }

    /// Every valid spec, in order.
    pub fn all() -> Vec<Self> {
        let mut out = Vec::new();
        for &method in EvalMethod::all() {
            let variants: Vec<CorrespondName> = if method.is_ssr() {
                CorrespondName::all().collect()
            } else {
                vec![CorrespondName::REFERENCE]
            };
            for c in variants {
                let finetunings = std::iter::once(None).chain(FinetuneProcedure::ALL.map(Some));
                for finetuned in finetunings {
                    for noisy in [false, true] {
                        let mut spec = Self::new(method);
                        spec.correspond = c;
                        if let Some(procedure) = finetuned {
                            let Ok(f) = spec.finetuned_by(procedure) else {
                                continue;
                            };
                            spec = f;
                        }
                        out.push(if noisy { spec.noisy() } else { spec });
                    }
                }
            }
        }
        out.sort();
        out
    }

    pub fn method(&self) -> EvalMethod {
        self.method
    }

    pub fn correspond(&self) -> CorrespondName {
        self.correspond
    }

    /// The unit of the C this run's records hold.
    pub fn c_unit(&self) -> CUnit {
        match self.correspond {
            CorrespondName::Plain => CUnit::Pixels,
            CorrespondName::Reference { .. } => CUnit::SquaredReferencePixels,
        }
    }

    pub fn is_finetuned(&self) -> bool {
        self.finetuned.is_some()
    }

    /// How the run was finetuned, if it was.
    pub fn finetune_procedure(&self) -> Option<FinetuneProcedure> {
        self.finetuned
    }

    pub fn is_noisy(&self) -> bool {
        self.noisy
    }

    pub fn is_ssr(&self) -> bool {
        self.method.is_ssr()
    }

    /// The most privileged information the run's method reads
    /// ([`EvalMethod::information`]).
    pub fn information(&self) -> Information {
        self.method.information()
    }

    /// The name the report and the page show (`SSR CCD`, `Good Robot
    /// finetuned`, `SSR CCD, sensor noise`, ...); the paper's table uses the
    /// same names.
    pub fn display_name(&self) -> String {
        let base = match (self.method, self.is_finetuned()) {
            (EvalMethod::Ssr(p), _) => p.def().display,
            (EvalMethod::SpotQ, false) => "SPOT-Q",
            (EvalMethod::SpotQ, true) => "Good Robot finetuned",
            (EvalMethod::Transporter, false) => "TransporterNet",
            (EvalMethod::Transporter, true) => "TransporterNet finetuned",
            (EvalMethod::Oracle, _) => "Oracle",
            (EvalMethod::Random, _) => "Random",
        };
        let finetuned = if self.is_finetuned() && self.is_ssr() {
            " finetuned"
        } else {
            ""
        };
        let adam = if self.finetuned == Some(FinetuneProcedure::Adam) {
            ", seespot's Adam variant"
        } else {
            ""
        };
        let noise = if self.noisy { ", sensor noise" } else { "" };
        let embeddings = self
            .embeddings
            .map(|e| format!(", embeddings: {}", e.as_str()))
            .unwrap_or_default();
        format!(
            "{base}{finetuned}{adam}{}{noise}{embeddings}",
            self.correspond.display_suffix()
        )
    }

    /// Whether the run's decisions use the test task's demonstrations (SSR,
    /// TransporterNet, the finetuned rows): the report counts their
    /// annotated actions.
    pub fn sees_demos(&self) -> bool {
        self.is_ssr() || self.method == EvalMethod::Transporter || self.is_finetuned()
    }

    /// What the run trained on its test task.
    pub fn task_training(&self) -> TaskTraining {
        match (self.method, self.finetuned) {
            (EvalMethod::Transporter, Some(_)) => TaskTraining::Finetuning { factor: 1 },
            (EvalMethod::Transporter, None) => TaskTraining::OwnTransporter,
            // "Good Robot" finetuned runs one model: the reference finetunes
            // it once; the Adam variant for three times the steps.
            (EvalMethod::SpotQ, Some(FinetuneProcedure::Reference)) => {
                TaskTraining::Finetuning { factor: 1 }
            }
            (_, Some(_)) => TaskTraining::Finetuning { factor: 3 },
            (EvalMethod::SpotQ, None) => TaskTraining::OwnSpotQ,
            _ => TaskTraining::Nothing,
        }
    }

    /// Why the debugger cannot run this run's trials again, if it cannot.
    /// It replays every run: SSR, SPOT-Q, TransporterNet, oracle and random
    /// trials, finetuned ones from their model files, noisy ones under the
    /// same seeded noise.
    pub fn replay_refusal(&self) -> Option<String> {
        None
    }
}

impl fmt::Display for RunSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let noise = if self.noisy { "-noisy" } else { "" };
        let adam = if self.finetuned == Some(FinetuneProcedure::Adam) {
            "-adam"
        } else {
            ""
        };
        if let Some(e) = self.embeddings {
            let base = Self {
                embeddings: None,
                ..*self
            };
            return write!(f, "{base}@{}", e.as_str());
        }
        match (self.method, self.is_finetuned()) {
            (EvalMethod::SpotQ, true) => write!(f, "good-robot-finetuned{adam}{noise}"),
            (EvalMethod::Transporter, true) => write!(f, "transporter-finetuned{noise}"),
            (m, finetuned) => {
                let suffix = if m.is_ssr() {
                    self.correspond.suffix()
                } else {
                    String::new()
                };
                let finetuned = if finetuned { "-finetuned" } else { "" };
                write!(f, "{}{suffix}{finetuned}{adam}{noise}", m.as_str())
            }
        }
    }
}

impl FromStr for RunSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if let Some((base, label)) = s.split_once('@') {
            return base
                .parse::<Self>()?
                .with_embeddings(EmbeddingLabel::new(label)?);
        }
        static NAMES: OnceLock<HashMap<String, RunSpec>> = OnceLock::new();
        let names = NAMES.get_or_init(|| {
            RunSpec::all()
                .into_iter()
                .map(|spec| (spec.to_string(), spec))
                .collect()
        });
        names.get(s).copied().ok_or_else(|| {
            format!(
                "`{s}` is not a seespot run name (a method, {}, with its variants, e.g. \
                 ssr-ccd-plain, ssr-ccd-finetuned, good-robot-finetuned, ssr-ccd-noisy, \
                 ssr-ccd@raw-patches)",
                EvalMethod::all()
                    .iter()
                    .map(|m| m.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
    }
}

impl serde::Serialize for RunSpec {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> serde::Deserialize<'de> for RunSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_spec_round_trips_through_its_name() {
        let all = RunSpec::all();
        // Every preset (SSR's methods) x 9 correspondences x 3 finetunings x
        // 2 noises, SPOT-Q x 3 x 2, TransporterNet x 2 x 2, oracle and
        // random x 2 (noise only).
        let ssr = seespot_ssr::preset::PRESETS.len();
        assert_eq!(all.len(), ssr * 9 * 6 + 6 + 4 + 2 * 2);
        let mut names = std::collections::HashSet::new();
        for spec in &all {
            let name = spec.to_string();
            assert!(names.insert(name.clone()), "two specs are named {name}");
            assert_eq!(name.parse::<RunSpec>(), Ok(*spec), "{name}");
            let json = serde_json::to_string(spec).expect("serialize");
            assert_eq!(
                serde_json::from_str::<RunSpec>(&json).expect("parse"),
                *spec
            );
        }
        // A run on an embedding set: `<run>@<set>`, for SSR and SPOT-Q only.
        let on_set: RunSpec = "ssr-ccd-noloops@raw-patches".parse().expect("parse");
        assert_eq!(on_set.to_string(), "ssr-ccd-noloops@raw-patches");
        assert_eq!(on_set.embeddings().map(|l| l.as_str()), Some("raw-patches"));
        assert!("oracle@raw-patches".parse::<RunSpec>().is_err());
        assert!("ssr-ccd-finetuned@raw-patches".parse::<RunSpec>().is_err());
        assert!("ssr-ccd@Raw Patches".parse::<RunSpec>().is_err());
        assert!("ssr-ccd-plian".parse::<RunSpec>().is_err());
        assert!("oracle-finetuned".parse::<RunSpec>().is_err());
        assert!("spot-q-plain".parse::<RunSpec>().is_err());
    }

    #[test]
    fn invalid_combinations_are_refused() {
        assert!(RunSpec::new(EvalMethod::Oracle).finetuned().is_err());
        assert!(
            RunSpec::new(EvalMethod::SpotQ)
                .with_correspond(CorrespondName::Plain)
                .is_err()
        );
        assert!(
            RunSpec::new(EvalMethod::SsrL2cd)
                .with_correspond(CorrespondName::Plain)
                .is_ok()
        );
    }

    #[test]
    fn the_names_of_the_table() {
        let ccd = RunSpec::new(EvalMethod::SsrCcd);
        for (spec, name, display) in [
            (ccd, "ssr-ccd", "SSR CCD"),
            (ccd.noisy(), "ssr-ccd-noisy", "SSR CCD, sensor noise"),
            (
                ccd.finetuned().expect("ssr"),
                "ssr-ccd-finetuned",
                "SSR CCD finetuned",
            ),
            (
                RunSpec::new(EvalMethod::SpotQ).finetuned().expect("spot-q"),
                "good-robot-finetuned",
                "Good Robot finetuned",
            ),
            (
                RunSpec::new(EvalMethod::SpotQ)
                    .finetuned_by(FinetuneProcedure::Adam)
                    .expect("spot-q"),
                "good-robot-finetuned-adam",
                "Good Robot finetuned, seespot's Adam variant",
            ),
            (
                ccd.finetuned_by(FinetuneProcedure::Adam).expect("ssr"),
                "ssr-ccd-finetuned-adam",
                "SSR CCD finetuned, seespot's Adam variant",
            ),
            (
                RunSpec::new(EvalMethod::SsrL2cd)
                    .with_correspond(CorrespondName::Plain)
                    .expect("ssr"),
                "ssr-l2cd-plain",
                "SSR L2CD, plain correspondence",
            ),
            (
                ccd.with_correspond(CorrespondName::Reference {
                    normalized: true,
                    demo_real: true,
                    global_rematch: true,
                })
                .expect("ssr")
                .finetuned()
                .expect("ssr")
                .noisy(),
                "ssr-ccd-normalized-demo-real-global-rematch-finetuned-noisy",
                "SSR CCD finetuned, normalized smoothing, real demo features, \
                 the reference runner's global rematch, sensor noise",
            ),
        ] {
            assert_eq!(spec.to_string(), name);
            assert_eq!(spec.display_name(), display);
        }
    }
}
