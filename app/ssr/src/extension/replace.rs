//! Replacing, seespot's extension of See-SPOT-Run (method
//! `ssr-ccd-replace`; docs/design.md §4.1).

use seespot_sim::{Action, Primitive};

use super::{Extension, LOOP_BREAK_RADIUS, Mask, Seen};
use crate::explain::REPLACED;

/// **Replacing (seespot's extension, not the paper's):** a place that left
/// progress where it was is not used again while progress stays. At each
/// grasp decision whose progress is the progress of the last grasp
/// decision, the place chosen between the two (if any) raised nothing; it
/// joins the replaced places, whose neighbourhood
/// ([`super::LOOP_BREAK_RADIUS`], every rotation) is masked at every place
/// decision until progress changes. A pick-and-put-back is one such place;
/// so is a block set down beside a row instead of at its end. The block
/// itself stays free to grasp (replacing takes the place of put-back
/// breaking's grasp mask), so SSR picks it again and sets it down at the
/// next-best place it finds. Reads progress.
#[derive(Clone, Debug, Default)]
pub struct Replacing {
    /// The progress at the last grasp decision, and the place chosen since.
    last: Option<(u8, Option<Action>)>,
    /// The places that left progress where it was, at the current progress.
    pub(crate) places: Vec<Action>,
}

impl Replacing {
    /// Called at each decision before it is made: updates the replaced places.
    pub(crate) fn observe(&mut self, progress: u8, primitive: Primitive) {
        if primitive != Primitive::Grasp {
            return;
        }
        match self.last.take() {
            Some((p, place)) if p == progress => {
                if let Some(place) = place
                    && !self.places.contains(&place)
                {
                    self.places.push(place);
                }
            }
            Some(_) => self.places.clear(),
            None => {}
        }
    }

    /// Called after a decision: remembers a grasp decision's progress and
    /// the place after it.
    pub(crate) fn chose(&mut self, progress: u8, action: Action) {
        match action.primitive {
            Primitive::Grasp => self.last = Some((progress, None)),
            Primitive::Place => {
                if let Some((_, place)) = &mut self.last {
                    *place = Some(action);
                }
            }
        }
    }
}

impl Extension for Replacing {
    fn before(&mut self, seen: &Seen, masks: &mut Vec<Mask>) {
        self.observe(seen.progress(), seen.primitive);
        masks.extend(
            self.places
                .iter()
                .map(|a| Mask::every(*a, LOOP_BREAK_RADIUS, REPLACED)),
        );
    }

    fn after(&mut self, seen: &Seen, action: Action) {
        self.chose(seen.progress(), action);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_place_that_raised_nothing_is_replaced_until_progress_changes() {
        let grasp = Action::new(Primitive::Grasp, 3, 40, 50);
        let place = Action::new(Primitive::Place, 5, 60, 70);
        let mut r = Replacing::default();
        r.observe(2, Primitive::Grasp);
        r.chose(2, grasp);
        // A grasp that lifted nothing: no place to judge.
        r.observe(2, Primitive::Grasp);
        assert!(r.places.is_empty());
        r.chose(2, grasp);
        r.observe(2, Primitive::Place);
        r.chose(2, place);
        assert!(r.places.is_empty(), "a place is judged at the next grasp");
        // Progress stayed: the place raised nothing, wherever the block went.
        r.observe(2, Primitive::Grasp);
        assert_eq!(r.places, vec![place]);
        // Another fruitless place joins it; the same place is named once.
        let other = Action::new(Primitive::Place, 1, 90, 20);
        for p in [other, place] {
            r.chose(2, grasp);
            r.observe(2, Primitive::Place);
            r.chose(2, p);
            r.observe(2, Primitive::Grasp);
        }
        assert_eq!(r.places, vec![place, other]);
        // A place that raised progress is not kept, and the others are forgotten.
        r.chose(2, grasp);
        r.observe(2, Primitive::Place);
        r.chose(2, other);
        r.observe(3, Primitive::Grasp);
        assert!(r.places.is_empty());
    }

    /// As an extension, at its declared level (progress; the heightmaps
    /// are not read).
    #[test]
    fn as_an_extension_it_reads_progress() {
        let trial = seespot_sim::Trial::new(
            seespot_sim::WorldConfig::default(),
            seespot_sim::TaskId::Row,
            1,
        );
        let hm = trial.world().render();
        let seen = |k| Seen::heightmaps(&hm, k, None, seespot_sim::TaskId::Row).with_progress(2);
        let place = Action::new(Primitive::Place, 5, 60, 70);
        let mut r = Replacing::default();
        let mut masks = Vec::new();
        r.before(&seen(Primitive::Grasp), &mut masks);
        r.after(
            &seen(Primitive::Grasp),
            Action::new(Primitive::Grasp, 3, 40, 50),
        );
        r.before(&seen(Primitive::Place), &mut masks);
        r.after(&seen(Primitive::Place), place);
        r.before(&seen(Primitive::Grasp), &mut masks);
        assert_eq!((masks[0].action, masks[0].why), (place, REPLACED));
    }
}
