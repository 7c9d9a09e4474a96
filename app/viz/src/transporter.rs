//! The TransporterNet baseline in the debugger: its pick (attention) and place
//! (transport) scores are shown in the views SSR's distance maps use.
//!
//! Each decision is one "pair" (the net and the test task's demonstration at
//! the analogous step). Its match map is the score map of the action taken,
//! at the action's rotation, as a distance: the best score minus each pixel's
//! score (0 at the chosen pixel, larger is worse, like an embedding distance);
//! `L` is that map's value at the action (0) and `C` is 0. There is no
//! rematch: the rematch map stays empty.

use crate::error::Context as _;
use std::time::Instant;

use seespot_policy::transporter::{TransporterMaps, from_grid, to_grid};
use seespot_policy::{TransporterActor, TransporterNet};
use seespot_sim::actor::{Actor, ActorError, Choice};
use seespot_sim::{Action, Demo, Heightmaps, Primitive, TaskId, Trial, WorldConfig};
use seespot_ssr::policy::{DemoQuery, demo_step};
use seespot_ssr::{Decision, Layout, Method, PairExplanation};

use crate::decider::{Decider, load_demos};

/// A TransporterNet that explains itself.
#[derive(Debug)]
pub struct TransporterDecider {
    actor: TransporterActor,
    task: TaskId,
    demos: Vec<Demo>,
    decision: Option<Decision>,
}

/// Loads `<models>/transporter/<task>.safetensors` and the task's demos (for
/// the page's demo panel).
pub fn load(
    task: TaskId,
    layout: &Layout,
    world: WorldConfig,
) -> crate::error::Result<(Box<dyn Decider>, String)> {
    let path = layout.transporter(task);
    let net =
        TransporterNet::load(&path).files(|| format!("cannot load the {task} TransporterNet"))?;
    let note = format!(
        "TransporterNet {} ({} iterations on the {task} demonstrations)",
        path.display(),
        net.meta.extra.get("iterations").map_or("?", |s| s.as_str())
    );
    with_net(task, net, note, layout, world)
}

/// The TransporterNet decider over a given net (a finetuned one, as an
/// evaluation made it), with `task`'s demonstrations from `layout`.
pub fn with_net(
    task: TaskId,
    net: TransporterNet,
    note: String,
    layout: &Layout,
    world: WorldConfig,
) -> crate::error::Result<(Box<dyn Decider>, String)> {
    let (demos, _) = load_demos(task, layout, world)?;
    Ok((
        Box::new(TransporterDecider {
            actor: TransporterActor::new(net),
            task,
            demos,
            decision: None,
        }),
        note,
    ))
}

/// The score map of `maps` for `action` (at its rotation) on the `h x h`
/// heightmap grid, as best score minus score.
fn distance_map(maps: &TransporterMaps, action: &Action, h: usize) -> Vec<f32> {
    let n = maps.n;
    let (scores, rotation) = match action.primitive {
        Primitive::Grasp => (&maps.attention, maps.pick.0),
        Primitive::Place => (&maps.transport, maps.place.0),
    };
    let plane = &scores[rotation * n * n..(rotation + 1) * n * n];
    let best = plane.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let mut out = Vec::with_capacity(h * h);
    for y in 0..h {
        for x in 0..h {
            out.push(best - plane[to_grid(y, h) * n + to_grid(x, h)]);
        }
    }
    out
}

impl TransporterDecider {
    fn explain(&self, trial: &Trial, hm: &Heightmaps, action: Action, ms: f64) -> Option<Decision> {
        let maps = self.actor.last_maps.as_ref()?;
        let h = hm.resolution();
        let progress = trial.progress();
        let (demo, step) = self
            .demos
            .iter()
            .enumerate()
            .find_map(|(i, d)| demo_step(d, progress, action.primitive).map(|s| (i, s)))?;
        let match_map = distance_map(maps, &action, h);
        // The chosen cell's pixel (the action may sit on any pixel of it).
        let (gy, gx) = match action.primitive {
            Primitive::Grasp => (maps.pick.1, maps.pick.2),
            Primitive::Place => (maps.place.1, maps.place.2),
        };
        let at = match_map[from_grid(gy, h) * h + from_grid(gx, h)];
        let pair = PairExplanation::of_map(
            self.task.to_string(),
            (demo, step, self.demos[demo].steps[step].meta.action),
            action,
            at,
            match_map,
        );
        Some(Decision::one_pair(
            Method::Transporter,
            progress,
            h,
            pair,
            ms,
        ))
    }
}

impl Actor for TransporterDecider {
    fn name(&self) -> String {
        self.actor.name()
    }

    fn begin_trial(&mut self, trial: &Trial) {
        self.actor.begin_trial(trial);
        self.decision = None;
    }

    fn act(&mut self, trial: &Trial, hm: &Heightmaps) -> Result<Choice, ActorError> {
        let t0 = Instant::now();
        let choice = self.actor.act(trial, hm)?;
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        self.decision = self.explain(trial, hm, choice.action, ms);
        Ok(choice)
    }
}

impl Decider for TransporterDecider {
    fn demos(&self) -> &[Demo] {
        &self.demos
    }

    fn policies(&self) -> Vec<String> {
        vec![self.task.to_string()]
    }

    fn decision(&self) -> Option<&Decision> {
        self.decision.as_ref()
    }

    fn query(&mut self, _: &Heightmaps, _: DemoQuery) -> crate::error::Result<Option<Vec<f32>>> {
        Ok(None)
    }
}
