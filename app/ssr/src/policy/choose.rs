//! Which pair SSR acts on (Eq. 8 for CCD, Eq. 9 for L2CD), and what a
//! record keeps of it.

use seespot_sim::actor::ChosenPair;

use crate::correspond::Correspondence;
use crate::explain::{Method, PairExplanation};

/// What a record keeps of the pair `chosen` that `method` acted on: its policy,
/// demonstration, L and C, and the action the other distance would have taken
/// in the same state (for counting how often SSR CCD and SSR L2CD differ).
pub fn chosen_pair(
    pairs: &[PairExplanation],
    chosen: usize,
    method: Method,
    mode: Correspondence,
) -> ChosenPair {
    let other = match method {
        Method::SsrCcd => Method::SsrL2cd,
        Method::SsrL2cd => Method::SsrCcd,
        Method::Transporter => Method::Transporter,
        Method::SpotQ => Method::SpotQ,
    };
    let p = &pairs[chosen];
    ChosenPair {
        policy: p.policy.clone(),
        demo: p.demo,
        l: p.l,
        c: p.c,
        other_method_action: pairs.get(choose(pairs, other, mode)).map(|o| o.matched),
        departures: Vec::new(),
        matches: pairs.iter().map(PairExplanation::pair_match).collect(),
    }
}

/// The pair SSR acts on (Eq. 8 for CCD, Eq. 9 for L2CD). Ties: with the
/// reference correspondence the first pair in (policy, demo) order (numpy's
/// argmin); with the plain one the other distance first, then the first pair.
pub fn choose(pairs: &[PairExplanation], method: Method, mode: Correspondence) -> usize {
    let second = |x: f32| match mode {
        Correspondence::Reference => 0.0,
        Correspondence::Plain => x,
    };
    let key = |p: &PairExplanation| match method {
        Method::SsrCcd => (p.c, second(p.l)),
        Method::SsrL2cd | Method::Transporter | Method::SpotQ => (p.l, second(p.c)),
    };
    let mut best = 0;
    for (i, p) in pairs.iter().enumerate() {
        let (a, b) = key(p);
        let (ba, bb) = key(&pairs[best]);
        if a.total_cmp(&ba).then(b.total_cmp(&bb)).is_lt() {
            best = i;
        }
    }
    best
}
