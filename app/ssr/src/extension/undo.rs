//! Undo (seespot's extension, not the paper's; `ssr-ccd-undo`): a grasp
//! after which progress fell took its block out of what was built (the row's
//! first block, a tower's top), so the place that follows puts it back: every
//! place but those within [`UNDO_RADIUS`] (or [`UNDO_WIDE_RADIUS`], the
//! `undo-wide` extension) of the grasp is masked. The built
//! guard then guards that spot, since the place raised progress again. It
//! learns the structure SSR did not build itself, which the built guard alone
//! cannot know. Reads the progress scalar P and SSR's own actions.

use seespot_sim::{Action, Primitive};

use super::{Extension, Mask, Seen};

/// Half the side of the square of places the undo keeps around the grasp
/// that lowered progress: 1 cm, a quarter of a block. Fixed before any run.
pub const UNDO_RADIUS: f32 = 0.01;

/// `undo-wide`'s half side: 3 cm. The test task's place mask keeps places
/// within 2.5 cm of an object, so a block lifted off the bare table (a row's
/// first block) leaves a spot 1 cm around which nothing may be placed, and
/// the undo gave way there in 31 of 39 validation cases (vertical square,
/// raw patches); 3 cm reaches into the mask from a neighbour 5 to 10 cm away.
pub const UNDO_WIDE_RADIUS: f32 = 0.03;

/// Why the undo masked every place but one spot.
pub const UNDONE: &str =
    "the grasp before lowered progress: its block goes back where it came from";

/// The last grasp and the progress before it.
#[derive(Clone, Debug)]
pub struct Undo {
    last_grasp: Option<(Action, u8)>,
    radius: f32,
}

impl Default for Undo {
    fn default() -> Self {
        Self::within(UNDO_RADIUS)
    }
}

impl Undo {
    /// An undo that keeps the places within `radius` metres of the grasp.
    pub fn within(radius: f32) -> Self {
        Self {
            last_grasp: None,
            radius,
        }
    }
}

impl Extension for Undo {
    fn before(&mut self, seen: &Seen, masks: &mut Vec<Mask>) {
        if seen.primitive != Primitive::Place {
            return;
        }
        if let Some((grasp, before)) = self.last_grasp.take()
            && seen.progress() < before
        {
            masks.push(Mask {
                yields: true,
                outside: true,
                ..Mask::every(
                    Action::new(Primitive::Place, grasp.rotation, grasp.y, grasp.x),
                    self.radius,
                    UNDONE,
                )
            });
        }
    }

    fn after(&mut self, seen: &Seen, action: Action) {
        if action.primitive == Primitive::Grasp {
            self.last_grasp = Some((action, seen.progress()));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use seespot_sim::{TaskId, Trial, WorldConfig};

    /// At its declared level (heightmaps and progress): a grasp that lowered
    /// progress sends the next place back to its spot; one that did not
    /// leaves the place free.
    #[test]
    fn a_grasp_that_lowered_progress_is_put_back() {
        let trial = Trial::new(WorldConfig::default(), TaskId::Row, 1);
        let hm = trial.world().render();
        let seen = |k, p| Seen::heightmaps(&hm, k, None, TaskId::Row).with_progress(p);
        let grasp = Action::new(Primitive::Grasp, 3, 40, 50);
        let mut u = Undo::default();
        let mut masks = Vec::new();
        u.after(&seen(Primitive::Grasp, 2), grasp);
        u.before(&seen(Primitive::Place, 2), &mut masks);
        assert!(masks.is_empty(), "progress stayed");
        u.after(
            &seen(Primitive::Place, 2),
            Action::new(Primitive::Place, 0, 9, 9),
        );
        u.after(&seen(Primitive::Grasp, 2), grasp);
        u.before(&seen(Primitive::Place, 1), &mut masks);
        assert_eq!(masks.len(), 1);
        let m = &masks[0];
        assert!(m.outside && m.yields && m.why == UNDONE);
        assert_eq!(
            (m.action.primitive, m.action.y, m.action.x),
            (Primitive::Place, 40, 50)
        );
        assert!(
            m.departure()
                .to_string()
                .starts_with("every place but the 1 cm around (40, 50)")
        );
        let mut wide = Undo::within(UNDO_WIDE_RADIUS);
        let mut masks = Vec::new();
        wide.after(&seen(Primitive::Grasp, 3), grasp);
        wide.before(&seen(Primitive::Place, 2), &mut masks);
        assert_eq!(masks[0].radius_m, UNDO_WIDE_RADIUS);
    }
}
