//! seespot's extensions of See-SPOT-Run, none of them the paper's: each one
//! a part that watches the trial through what it is allowed to see and masks
//! actions before SSR's Correspond step, with the reason the page, the
//! recordings and the records show ([`Mask::why`]).
//!
//! An extension is one module here and one row of [`REGISTRY`]: its name,
//! the most privileged [`Information`] it reads, the extensions it needs
//! and how to make a fresh one for a trial. It implements [`Extension`]:
//! [`Extension::before`] sees the scene of the next decision ([`Seen`]) and
//! adds its masks, [`Extension::after`] hears the action chosen. What
//! [`Seen`] hands an extension is cut to its declared information: an
//! extension that declares heightmaps and asks for progress, or declares
//! progress and asks for the simulator, panics (each module's tests run it
//! at its declared level). Method names ([`crate::preset`]) are sets of
//! extensions on top of a rule (CCD or L2CD).

mod built_guard;
mod guard;
mod loop_break;
mod put_back;
mod regrasp;
mod replace;
mod undo;

pub use guard::guarded_blocks;
pub use loop_break::LoopBreak;
pub use put_back::PutBack;
pub use regrasp::{regrasp_applies, regrasp_rotations};
pub use replace::Replacing;

use seespot_sim::record::Departure;
use seespot_sim::{Action, Heightmaps, Primitive, TaskId, Trial};

pub use crate::explain::{GUARD_RADIUS, LOOP_BREAK_RADIUS};

/// What an extension reads, from the least to the most privileged; a run is
/// labelled by the most privileged information any of its parts reads.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    PartialOrd,
    Ord,
    serde::Serialize,
    serde::Deserialize,
    strum::IntoStaticStr,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case")]
pub enum Information {
    /// The heightmaps SSR sees, and SSR's own past actions.
    Heightmaps,
    /// The progress scalar P that SSR already reads to pick demo steps.
    Progress,
    /// The simulator's state: block poses, scenes SSR has not seen (a
    /// privileged upper reference, not a method a robot could run as is).
    Simulator,
}

impl Information {
    pub fn as_str(self) -> &'static str {
        self.into()
    }

    /// What the label means, in a sentence's words.
    pub fn words(self) -> &'static str {
        match self {
            Self::Heightmaps => "heightmaps only (what See-SPOT-Run sees)",
            Self::Progress => "heightmaps and the progress scalar See-SPOT-Run already reads",
            Self::Simulator => {
                "the simulator's state (block poses, unseen scenes): a privileged upper reference"
            }
        }
    }
}

/// The scene of the next decision, as one extension may see it.
#[derive(Clone, Copy, Debug)]
pub struct Seen<'a> {
    /// The live heightmaps.
    pub hm: &'a Heightmaps,
    /// The primitive of the next action.
    pub primitive: Primitive,
    /// SSR's last action, when it left the scene exactly as it was (the same
    /// heightmaps, progress and primitive): an action that did nothing.
    pub repeat: Option<Action>,
    /// The test task (the method's input, as the demonstrations are).
    pub task: TaskId,
    progress: Option<u8>,
    trial: Option<&'a Trial>,
}

impl<'a> Seen<'a> {
    /// The scene with everything in it, cut to `level` by [`Seen::at`].
    pub fn new(
        hm: &'a Heightmaps,
        primitive: Primitive,
        repeat: Option<Action>,
        task: TaskId,
        progress: u8,
        trial: &'a Trial,
    ) -> Self {
        Self {
            trial: Some(trial),
            ..Self::heightmaps(hm, primitive, repeat, task).with_progress(progress)
        }
    }

    /// Only what `level` may read: no progress below [`Information::Progress`],
    /// no simulator below [`Information::Simulator`].
    pub fn at(self, level: Information) -> Self {
        Self {
            progress: self.progress.filter(|_| level >= Information::Progress),
            trial: self.trial.filter(|_| level >= Information::Simulator),
            ..self
        }
    }

    /// Heightmaps alone, as a heightmaps-level extension's tests build it.
    pub fn heightmaps(
        hm: &'a Heightmaps,
        primitive: Primitive,
        repeat: Option<Action>,
        task: TaskId,
    ) -> Self {
        Self {
            hm,
            primitive,
            repeat,
            task,
            progress: None,
            trial: None,
        }
    }

    /// With progress `p` (a progress-level extension's tests).
    pub fn with_progress(self, p: u8) -> Self {
        Self {
            progress: Some(p),
            ..self
        }
    }

    /// The progress P. Panics for an extension that declared heightmaps.
    pub fn progress(&self) -> u8 {
        self.progress.expect(
            "an extension that declares heightmaps read progress: declare Information::Progress",
        )
    }

    /// The simulator's trial. Panics for an extension that did not declare
    /// the simulator.
    pub fn trial(&self) -> &'a Trial {
        self.trial
            .expect("an extension read the simulator's state: declare Information::Simulator")
    }
}

/// Which rotations a mask covers around its action.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Around {
    /// Every rotation.
    Every,
    /// The action's grasp axis only ([`regrasp_rotations`]).
    Axis,
}

/// One masked neighbourhood: the square of half side `radius_m` (metres)
/// around `action`'s pixel, at the rotations `around` names, masked for the
/// next decision because `why`.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    pub action: Action,
    pub radius_m: f32,
    pub around: Around,
    pub why: &'static str,
    /// Whether the mask gives way first when the masks together would leave
    /// no action allowed (then every mask gives way).
    pub yields: bool,
    /// Masks every action of the primitive *but* the square (sends the
    /// decision there) instead of the square.
    pub outside: bool,
}

impl Mask {
    /// A mask of every rotation that stands until nothing is left.
    pub fn every(action: Action, radius_m: f32, why: &'static str) -> Self {
        Self {
            action,
            radius_m,
            around: Around::Every,
            why,
            yields: false,
            outside: false,
        }
    }

    /// The record of the mask: the action, the neighbourhood and why.
    pub fn departure(&self) -> Departure {
        Departure {
            action: self.action,
            radius_m: self.radius_m,
            why: self.why.to_owned(),
            outside: self.outside,
        }
    }
}

/// One extension of See-SPOT-Run, fresh for each trial.
pub trait Extension: std::fmt::Debug + Send + Sync {
    /// Before a decision in `seen`: updates what the extension knows and adds
    /// its masks to `masks`, which holds the masks of the extensions before
    /// it in [`REGISTRY`] order (an extension may refine one of theirs, as
    /// regrasp narrows loop breaking's). Masks of the other primitive are
    /// dropped by the policy.
    fn before(&mut self, seen: &Seen, masks: &mut Vec<Mask>);

    /// After the decision: the action chosen in `seen`.
    fn after(&mut self, _seen: &Seen, _action: Action) {}
}

/// An extension's row in the registry.
pub struct ExtensionDef {
    /// The name Python and the presets use.
    pub name: &'static str,
    /// The most privileged information it reads.
    pub information: Information,
    /// The extensions it needs in the same set (without them it would
    /// silently do nothing); `a|b` needs one of them.
    pub needs: &'static [&'static str],
    /// What it does, in a phrase (a method's title joins them).
    pub phrase: &'static str,
    /// A fresh one for a trial.
    pub make: fn() -> Box<dyn Extension>,
}

/// Every extension, in the order they run at each decision (the order of a
/// decision's departures).
pub const REGISTRY: &[ExtensionDef] = &[
    ExtensionDef {
        name: "loop-break",
        information: Information::Heightmaps,
        needs: &[],
        phrase: "loop breaking",
        make: || Box::<LoopBreak>::default(),
    },
    ExtensionDef {
        name: "regrasp",
        information: Information::Heightmaps,
        needs: &["loop-break"],
        phrase: "regrasp",
        make: || Box::<regrasp::Regrasp>::default(),
    },
    ExtensionDef {
        name: "put-back-break",
        information: Information::Progress,
        needs: &[],
        phrase: "put-back breaking",
        make: || Box::<PutBack>::default(),
    },
    ExtensionDef {
        name: "replace",
        information: Information::Progress,
        needs: &[],
        phrase: "replacing",
        make: || Box::<Replacing>::default(),
    },
    ExtensionDef {
        name: "reversal-guard",
        information: Information::Simulator,
        needs: &[],
        phrase: "reversal guard",
        make: || Box::<guard::ReversalGuard>::default(),
    },
    ExtensionDef {
        name: "built-guard",
        information: Information::Progress,
        needs: &[],
        phrase: "built guard",
        make: || Box::<built_guard::BuiltGuard>::default(),
    },
    ExtensionDef {
        name: "built-guard-wide",
        information: Information::Progress,
        needs: &[],
        phrase: "built guard (3.75 cm)",
        make: || {
            Box::new(built_guard::BuiltGuard::within(
                built_guard::BUILT_WIDE_RADIUS,
            ))
        },
    },
    ExtensionDef {
        name: "undo",
        information: Information::Progress,
        needs: &["built-guard|built-guard-wide"],
        phrase: "undo",
        make: || Box::<undo::Undo>::default(),
    },
    ExtensionDef {
        name: "undo-wide",
        information: Information::Progress,
        needs: &["built-guard|built-guard-wide"],
        phrase: "undo (3 cm)",
        make: || Box::new(undo::Undo::within(undo::UNDO_WIDE_RADIUS)),
    },
];

/// A set of extensions (an index set into [`REGISTRY`]), iterated in
/// registry order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Extensions(u64);

impl Extensions {
    pub const NONE: Self = Self(0);

    /// The set of the extensions named in `names`, checked: every name known
    /// and every extension's needs in the set.
    pub fn named(names: &[&str]) -> Result<Self, String> {
        let mut set = Self::NONE;
        for name in names {
            let i = REGISTRY
                .iter()
                .position(|d| d.name == *name)
                .ok_or_else(|| {
                    format!(
                        "unknown extension `{name}`{} (expected one of: {})",
                        seespot_sim::bounds::did_you_mean(name, REGISTRY.iter().map(|d| d.name)),
                        REGISTRY
                            .iter()
                            .map(|d| d.name)
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                })?;
            set.0 |= 1 << i;
        }
        for d in set.defs() {
            for need in d.needs {
                if !need.split('|').any(|n| set.defs().any(|e| e.name == n)) {
                    return Err(format!(
                        "extension `{}` needs `{need}`: without it, it would do nothing",
                        d.name
                    ));
                }
            }
        }
        Ok(set)
    }

    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The rows of the set's extensions, in registry order.
    pub fn defs(self) -> impl Iterator<Item = &'static ExtensionDef> {
        REGISTRY
            .iter()
            .enumerate()
            .filter(move |(i, _)| self.0 & (1 << i) != 0)
            .map(|(_, d)| d)
    }

    /// The names, in registry order.
    pub fn names(self) -> Vec<&'static str> {
        self.defs().map(|d| d.name).collect()
    }

    /// The most privileged information the set reads (heightmaps for none).
    pub fn information(self) -> Information {
        self.defs()
            .map(|d| d.information)
            .max()
            .unwrap_or(Information::Heightmaps)
    }

    /// Fresh extensions for a trial, each with the level it may see.
    pub fn make(self) -> Vec<(Information, Box<dyn Extension>)> {
        self.defs().map(|d| (d.information, (d.make)())).collect()
    }
}

/// The pixels `masks` forbid in live maps of `rotations` x `n` x `n`
/// actions with pixels of side `pixel` (metres).
pub fn forbidden(masks: &[Mask], rotations: usize, n: usize, pixel: f32) -> Vec<bool> {
    let mut forbid = vec![false; rotations * n * n];
    let every: Vec<usize> = (0..rotations).collect();
    for m in masks {
        let a = &m.action;
        let r = (m.radius_m / pixel).round() as usize;
        let axis;
        let on: &[usize] = match m.around {
            Around::Every => &every,
            Around::Axis => {
                axis = regrasp_rotations(a.rotation, rotations);
                &axis
            }
        };
        let (ys, xs) = (
            a.y.saturating_sub(r)..=(a.y + r).min(n - 1),
            a.x.saturating_sub(r)..=(a.x + r).min(n - 1),
        );
        for &k in on {
            let plane = &mut forbid[k * n * n..(k + 1) * n * n];
            if m.outside {
                // Everything but the square: the whole plane is visited.
                for (i, f) in plane.iter_mut().enumerate() {
                    *f |= !(ys.contains(&(i / n)) && xs.contains(&(i % n)));
                }
            } else {
                // The square alone, not the plane (every decision's masks).
                for y in ys.clone() {
                    plane[y * n + xs.start()..=y * n + xs.end()].fill(true);
                }
            }
        }
    }
    forbid
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_set_is_checked_and_labelled_by_its_most_privileged_part() {
        assert!(Extensions::named(&["regrasp"]).is_err(), "regrasp alone");
        let err = Extensions::named(&["loop-brake"]).expect_err("a typo");
        assert!(err.contains("loop-break"), "{err}");
        let fair = Extensions::named(&["replace", "regrasp", "loop-break"]).expect("valid");
        // Registry order, whatever the order asked.
        assert_eq!(fair.names(), ["loop-break", "regrasp", "replace"]);
        assert_eq!(fair.information(), Information::Progress);
        let guarded = Extensions::named(&["loop-break", "reversal-guard"]).expect("valid");
        assert_eq!(guarded.information(), Information::Simulator);
        assert_eq!(Extensions::NONE.information(), Information::Heightmaps);
        assert!(Extensions::named(&[]).expect("none").is_empty());
    }

    #[test]
    fn every_registered_name_is_unique_and_its_needs_are_registered() {
        for (i, d) in REGISTRY.iter().enumerate() {
            assert!(REGISTRY[..i].iter().all(|e| e.name != d.name), "{}", d.name);
            for need in d.needs.iter().flat_map(|n| n.split('|')) {
                assert!(REGISTRY.iter().any(|e| e.name == need), "{need}");
            }
        }
        assert!(REGISTRY.len() <= 64, "the set is a 64-bit mask");
    }

    #[test]
    fn a_mask_is_recorded_as_a_departure_in_the_page_s_words() {
        let a = Action::new(Primitive::Grasp, 3, 40, 50);
        let m = Mask::every(a, LOOP_BREAK_RADIUS, crate::explain::LEFT_UNCHANGED);
        assert_eq!(
            m.departure().to_string(),
            "grasp r3 (40, 50) and the 2 cm around it skipped: it left the scene unchanged"
        );
    }

    #[test]
    fn masks_forbid_their_square_at_their_rotations() {
        let a = Action::new(Primitive::Grasp, 3, 10, 10);
        let every = Mask::every(a, 0.004, "x");
        let n = 32;
        let forbid = forbidden(std::slice::from_ref(&every), 16, n, 0.002);
        // 2 px either way, every rotation: 5 x 5 x 16.
        assert_eq!(forbid.iter().filter(|&&f| f).count(), 25 * 16);
        let axis = Mask {
            around: Around::Axis,
            ..every
        };
        let forbid = forbidden(&[axis], 16, n, 0.002);
        assert_eq!(forbid.iter().filter(|&&f| f).count(), 25 * 6);
        assert!(forbid[(3 * n + 10) * n + 10] && !forbid[(5 * n + 10) * n + 10]);
        // Outside: everything but the square, at every rotation.
        let outside = Mask {
            outside: true,
            ..every
        };
        let forbid = forbidden(&[outside], 16, n, 0.002);
        assert_eq!(forbid.iter().filter(|&&f| !f).count(), 25 * 16);
        assert!(!forbid[(3 * n + 10) * n + 10] && forbid[(3 * n + 20) * n + 20]);
    }

    #[test]
    fn seen_cuts_what_a_level_may_read() {
        let trial = Trial::new(seespot_sim::WorldConfig::default(), TaskId::Stack, 1);
        let hm = trial.world().render();
        let all = Seen::new(&hm, Primitive::Grasp, None, TaskId::Stack, 2, &trial);
        assert_eq!(all.at(Information::Progress).progress(), 2);
        assert!(all.at(Information::Progress).trial.is_none());
        assert!(all.at(Information::Heightmaps).progress.is_none());
        let sim = all.at(Information::Simulator);
        assert_eq!(sim.trial().seed(), 1);
    }

    #[test]
    #[should_panic(expected = "declare Information::Progress")]
    fn a_heightmaps_extension_cannot_read_progress() {
        let trial = Trial::new(seespot_sim::WorldConfig::default(), TaskId::Stack, 1);
        let hm = trial.world().render();
        Seen::heightmaps(&hm, Primitive::Grasp, None, TaskId::Stack).progress();
    }
}
