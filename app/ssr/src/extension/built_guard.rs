//! The built guard (seespot's extension, not the paper's; `ssr-ccd-built`):
//! the reversal guard's aim without the simulator. A place after which
//! progress rose put its block into what is built, so no grasp is taken
//! there while that progress stands; when progress falls below it, the
//! spot is free again. Reads the progress scalar P that SSR already reads
//! and SSR's own actions: no block pose, no unseen scene.

use seespot_sim::{Action, Primitive};

use super::{Extension, GUARD_RADIUS, Mask, Seen};

/// Why the built guard masked a grasp.
pub const BUILT: &str =
    "a place there raised progress: its block is part of what is built while that progress stands";

/// `built-guard-wide`'s half side: three quarters of a block (3.75 cm). A
/// block settles up to a few millimetres from the place's pixel and its top
/// reaches 3.5 cm from its centre along a diagonal, so half a block
/// ([`GUARD_RADIUS`]) left grasps on a guarded block's edges allowed; on the
/// validation seeds SSR then grasped the guarded tower's edge 2.8 to 3 cm
/// from the place, over and over (vertical square, raw patches, seed 10009).
pub const BUILT_WIDE_RADIUS: f32 = 0.75 * seespot_sim::blocks::BLOCK_SIZE;

/// The spots of the places that raised progress.
#[derive(Clone, Debug)]
pub struct BuiltGuard {
    /// The last place and the progress before it.
    last_place: Option<(Action, u8)>,
    /// Each spot (as a grasp at rotation 0) and the progress its place reached.
    built: Vec<(Action, u8)>,
    /// The half side of the square masked around each spot.
    radius: f32,
}

impl Default for BuiltGuard {
    fn default() -> Self {
        Self::within(GUARD_RADIUS)
    }
}

impl BuiltGuard {
    /// A built guard that masks the grasps within `radius` metres of a spot.
    pub fn within(radius: f32) -> Self {
        Self {
            last_place: None,
            built: Vec::new(),
            radius,
        }
    }
}

impl Extension for BuiltGuard {
    fn before(&mut self, seen: &Seen, masks: &mut Vec<Mask>) {
        if seen.primitive != Primitive::Grasp {
            return;
        }
        let p = seen.progress();
        if let Some((place, before)) = self.last_place.take()
            && p > before
        {
            self.built
                .push((Action::new(Primitive::Grasp, 0, place.y, place.x), p));
        }
        self.built.retain(|(_, level)| *level <= p);
        masks.extend(self.built.iter().map(|(a, _)| Mask {
            yields: true,
            ..Mask::every(*a, self.radius, BUILT)
        }));
    }

    fn after(&mut self, seen: &Seen, action: Action) {
        if action.primitive == Primitive::Place {
            self.last_place = Some((action, seen.progress()));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use seespot_sim::{TaskId, Trial, WorldConfig};

    /// At its declared level (heightmaps and progress): a place that raised
    /// progress guards its spot until progress falls below what it reached;
    /// a place that raised nothing guards nothing.
    #[test]
    fn a_place_that_raised_progress_is_guarded_while_progress_stands() {
        let trial = Trial::new(WorldConfig::default(), TaskId::Stack, 1);
        let hm = trial.world().render();
        let seen = |k, p| Seen::heightmaps(&hm, k, None, TaskId::Stack).with_progress(p);
        let (grasp, place) = (
            Action::new(Primitive::Grasp, 3, 40, 50),
            Action::new(Primitive::Place, 5, 60, 70),
        );
        let mut g = BuiltGuard::default();
        let mut masks = Vec::new();
        g.before(&seen(Primitive::Grasp, 1), &mut masks);
        g.after(&seen(Primitive::Grasp, 1), grasp);
        g.before(&seen(Primitive::Place, 1), &mut masks);
        g.after(&seen(Primitive::Place, 1), place);
        assert!(masks.is_empty());
        // Progress rose: the place's spot is guarded, at every rotation.
        g.before(&seen(Primitive::Grasp, 2), &mut masks);
        assert_eq!(masks.len(), 1);
        let m = &masks[0];
        assert_eq!(
            (m.action.y, m.action.x, m.action.primitive),
            (60, 70, Primitive::Grasp)
        );
        assert!(m.yields && m.why == BUILT && m.radius_m == GUARD_RADIUS);
        // A place that left progress where it was adds nothing.
        g.after(&seen(Primitive::Grasp, 2), grasp);
        g.before(&seen(Primitive::Place, 2), &mut masks);
        g.after(
            &seen(Primitive::Place, 2),
            Action::new(Primitive::Place, 0, 9, 9),
        );
        masks.clear();
        g.before(&seen(Primitive::Grasp, 2), &mut masks);
        assert_eq!(masks.len(), 1);
        // Progress fell below what the place reached: the spot is free.
        masks.clear();
        g.before(&seen(Primitive::Grasp, 1), &mut masks);
        assert!(masks.is_empty());
        // The wide guard masks three quarters of a block around the spot.
        let mut wide = BuiltGuard::within(BUILT_WIDE_RADIUS);
        wide.after(&seen(Primitive::Place, 1), place);
        wide.before(&seen(Primitive::Grasp, 2), &mut masks);
        assert!(
            (masks[0].radius_m - 0.0375).abs() < 1e-6,
            "{}",
            masks[0].radius_m
        );
    }
}
