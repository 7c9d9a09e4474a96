//! A [`TransporterNet`] driving a trial: at each grasp it plans the grasp and
//! the place from the same observation; the place is executed when the trial
//! asks for one.

use seespot_sim::{Action, Actor, ActorError, Choice, Heightmaps, Primitive, Trial};

use super::{TransporterMaps, TransporterNet};

/// The TransporterNet baseline as an [`Actor`].
#[derive(Clone, Debug)]
pub struct TransporterActor {
    pub net: TransporterNet,
    /// The place planned with the last grasp, not yet executed.
    planned_place: Option<Action>,
    /// The score maps of the last plan (for the debugger).
    pub last_maps: Option<TransporterMaps>,
}

impl TransporterActor {
    pub fn new(net: TransporterNet) -> Self {
        Self {
            net,
            planned_place: None,
            last_maps: None,
        }
    }
}

impl Actor for TransporterActor {
    fn name(&self) -> String {
        format!("TransporterNet ({} demonstrations)", self.net.meta.task)
    }

    fn begin_trial(&mut self, _trial: &Trial) {
        self.planned_place = None;
        self.last_maps = None;
    }

    fn act(&mut self, trial: &Trial, hm: &Heightmaps) -> Result<Choice, ActorError> {
        let primitive = trial.world().next_primitive();
        if primitive == Primitive::Place
            && let Some(place) = self.planned_place.take()
        {
            return Ok(place.into());
        }
        // A grasp (or a place with no plan, as when a trial is picked up
        // mid-way): plan both from this observation.
        let (grasp, place, maps) = self.net.plan(hm)?;
        self.last_maps = Some(maps);
        Ok(match primitive {
            Primitive::Grasp => {
                self.planned_place = Some(place);
                grasp.into()
            }
            Primitive::Place => place.into(),
        })
    }
}
