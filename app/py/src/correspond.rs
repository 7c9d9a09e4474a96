//! Correspond on bring-your-own embeddings: match (Eq. 4-5), rematch (Eq. 6)
//! and the cycle consistency distance C (Eq. 7) over any `float32[R, H, W, D]`
//! action-state embeddings, e.g. from a PyTorch network. These are the plain
//! formulation of `seespot_ssr::correspond` (no smoothing, no rematch window).

use numpy::IntoPyArray;
use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use seespot_policy::AseMap;
use seespot_sim::{Action, Primitive};

use crate::arrays::{self, bad};
use crate::ssr::action_tuple;

/// An ASE map from a `float32[R, H, W, D]` array (H = W) and an optional
/// `bool[R, H, W]` mask (true = allowed).
fn ase_map(
    features: &Bound<'_, PyAny>,
    arg: &str,
    mask: Option<&Bound<'_, PyAny>>,
    mask_arg: &str,
) -> PyResult<AseMap> {
    let (f, s) = arrays::f32_array(features, arg, 4)?;
    if s.contains(&0) || s[1] != s[2] {
        return Err(bad(
            arg,
            format!("expected shape (R, H, H, D) with nothing empty, got {s:?}"),
        ));
    }
    let mask = match mask {
        None => vec![true; s[0] * s[1] * s[2]],
        Some(m) => {
            let (m, ms) = arrays::bool_array(m, mask_arg, 3)?;
            if ms[..] != s[..3] {
                return Err(bad(
                    mask_arg,
                    format!(
                        "shape {ms:?} does not match {arg}'s (R, H, W) {:?}",
                        &s[..3]
                    ),
                ));
            }
            m
        }
    };
    Ok(AseMap::new(Primitive::Grasp, s[1], s[0], s[3], f, mask))
}

/// A `(rotation, y, x)` action inside `map`.
fn action_in(map: &AseMap, a: (i64, i64, i64), arg: &str) -> PyResult<Action> {
    let (r, y, x) = a;
    let n = map.resolution as i64;
    if !(0..map.rotations as i64).contains(&r) || !(0..n).contains(&y) || !(0..n).contains(&x) {
        return Err(bad(
            arg,
            format!("({r}, {y}, {x}) is outside ({}, {n}, {n})", map.rotations),
        ));
    }
    Ok(Action::new(
        map.primitive,
        r as usize,
        y as usize,
        x as usize,
    ))
}

fn check_dim(map: &AseMap, d: usize, arg: &str, what: &str) -> PyResult<()> {
    if d != map.dim {
        return Err(bad(
            arg,
            format!("D = {d} does not match {what}'s D = {}", map.dim),
        ));
    }
    Ok(())
}

/// Match (Eq. 4-5): for each query embedding (`float32[Q, D]`), the nearest
/// allowed action of `live` (`float32[R, H, W, D]`, optional `bool[R, H, W]`
/// `mask`). Returns `(actions int64[Q, 3]` as (rotation, y, x)`, distances
/// float32[Q])`, distances L2 in embedding space.
#[pyfunction]
#[pyo3(signature = (live, queries, mask = None))]
#[allow(clippy::type_complexity)]
pub fn match_queries<'py>(
    py: Python<'py>,
    live: &Bound<'py, PyAny>,
    queries: &Bound<'py, PyAny>,
    mask: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyArray2<i64>>, Bound<'py, PyArray1<f32>>)> {
    let map = ase_map(live, "live", mask, "mask")?;
    let (q, qs) = arrays::f32_array(queries, "queries", 2)?;
    check_dim(&map, qs[1], "queries", "live")?;
    let matches = py.detach(|| {
        let rows: Vec<&[f32]> = q.chunks_exact(map.dim.max(1)).collect();
        seespot_ssr::correspond::match_queries(&map, &rows)
    });
    let mut actions = Vec::with_capacity(matches.len() * 3);
    for m in &matches {
        let (r, y, x) = action_tuple(&m.action(map.primitive, map.resolution));
        actions.extend([r as i64, y as i64, x as i64]);
    }
    let actions =
        Array2::from_shape_vec((matches.len(), 3), actions).map_err(|e| bad("queries", e))?;
    let distances: Vec<f32> = matches.iter().map(|m| m.distance).collect();
    Ok((actions.into_pyarray(py), distances.into_pyarray(py)))
}

/// Rematch (Eq. 6): the nearest allowed action of `demo` (`float32[R, H, W, D]`)
/// to `query` (`float32[D]`), within rotation `rotation` when given. Returns
/// `((rotation, y, x), distance)`.
#[pyfunction]
#[pyo3(signature = (demo, query, rotation = None, mask = None))]
pub fn rematch(
    py: Python<'_>,
    demo: &Bound<'_, PyAny>,
    query: &Bound<'_, PyAny>,
    rotation: Option<i64>,
    mask: Option<&Bound<'_, PyAny>>,
) -> PyResult<((usize, usize, usize), f32)> {
    let map = ase_map(demo, "demo", mask, "mask")?;
    let (q, qs) = arrays::f32_array(query, "query", 1)?;
    check_dim(&map, qs[0], "query", "demo")?;
    let rotation = match rotation {
        None => None,
        Some(r) if (0..map.rotations as i64).contains(&r) => Some(r as usize),
        Some(r) => {
            return Err(bad(
                "rotation",
                format!("{r} is outside 0..{}", map.rotations),
            ));
        }
    };
    let m = py.detach(|| seespot_ssr::correspond::rematch(&map, &q, rotation));
    if !m.distance.is_finite() {
        return Err(bad("mask", "masks every action searched"));
    }
    Ok((
        action_tuple(&m.action(map.primitive, map.resolution)),
        m.distance,
    ))
}

/// C (Eq. 7): the Euclidean distance between the `(rotation, y, x)` indices of
/// the demonstrated action and its rematch.
#[pyfunction]
pub fn ccd(demo_action: (i64, i64, i64), rematch: (i64, i64, i64)) -> PyResult<f32> {
    let check = |a: (i64, i64, i64), arg: &str| {
        if a.0 < 0 || a.1 < 0 || a.2 < 0 {
            Err(bad(arg, format!("{a:?} has a negative index")))
        } else {
            Ok(Action::new(
                Primitive::Grasp,
                a.0 as usize,
                a.1 as usize,
                a.2 as usize,
            ))
        }
    };
    Ok(seespot_ssr::correspond::ccd(
        &check(demo_action, "demo_action")?,
        &check(rematch, "rematch")?,
    ))
}

/// One (policy, demo) pair of Correspond on your own embeddings: the demo
/// action's embedding in `demo` is matched into `live` (L, F: Eq. 4-5), F's
/// embedding is rematched into `demo` within the demo action's rotation (Eq. 6),
/// and C is the distance between the demo action and the rematch (Eq. 7).
/// `live` and `demo` are `float32[R, H, W, D]` with the same R, H, W, D.
/// Returns a dict with `matched`, `l`, `rematch`, `rematch_l`, `c`, and the
/// `float32[H, W]` distance maps `match_map` (live, matched rotation) and
/// `rematch_map` (demo, demo action's rotation).
#[pyfunction]
#[pyo3(signature = (live, demo, demo_action, live_mask = None, demo_mask = None))]
pub fn correspond<'py>(
    py: Python<'py>,
    live: &Bound<'py, PyAny>,
    demo: &Bound<'py, PyAny>,
    demo_action: (i64, i64, i64),
    live_mask: Option<&Bound<'py, PyAny>>,
    demo_mask: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let live = ase_map(live, "live", live_mask, "live_mask")?;
    let demo = ase_map(demo, "demo", demo_mask, "demo_mask")?;
    if (demo.rotations, demo.resolution, demo.dim) != (live.rotations, live.resolution, live.dim) {
        return Err(bad(
            "demo",
            format!(
                "shape ({}, {n}, {n}, {}) does not match live's ({}, {m}, {m}, {})",
                demo.rotations,
                demo.dim,
                live.rotations,
                live.dim,
                n = demo.resolution,
                m = live.resolution
            ),
        ));
    }
    let a = action_in(&demo, demo_action, "demo_action")?;
    let n = live.resolution;
    let (m, re, match_map, rematch_map) = py.detach(|| {
        use seespot_ssr::correspond as c;
        let q = demo.feature(a.flat_index(n));
        let m = c::match_queries(&live, &[q])[0];
        let f = m.action(live.primitive, n);
        let fq = live.feature(m.index.min(live.len() - 1));
        let re = c::rematch(&demo, fq, Some(a.rotation));
        let match_map = c::distance_map(&live, q, f.rotation);
        let rematch_map = c::distance_map(&demo, fq, a.rotation);
        (m, re, match_map, rematch_map)
    });
    if !m.distance.is_finite() || !re.distance.is_finite() {
        return Err(bad("live_mask/demo_mask", "masks every action searched"));
    }
    let f = m.action(live.primitive, n);
    let r = re.action(demo.primitive, n);
    let d = PyDict::new(py);
    d.set_item("demo_action", action_tuple(&a))?;
    d.set_item("matched", action_tuple(&f))?;
    d.set_item("l", m.distance)?;
    d.set_item("rematch", action_tuple(&r))?;
    d.set_item("rematch_l", re.distance)?;
    d.set_item("c", seespot_ssr::correspond::ccd(&a, &r))?;
    for (key, map) in [("match_map", match_map), ("rematch_map", rematch_map)] {
        let arr = Array2::from_shape_vec((n, n), map).map_err(|e| bad(key, e))?;
        d.set_item(key, arr.into_pyarray(py))?;
    }
    Ok(d)
}

/// The `float32[H, W]` map of L2 distances from `query` (`float32[D]`) to every
/// action of rotation `rotation` in `embeddings` (`float32[R, H, W, D]`).
#[pyfunction]
pub fn distance_map<'py>(
    py: Python<'py>,
    embeddings: &Bound<'py, PyAny>,
    query: &Bound<'py, PyAny>,
    rotation: i64,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let map = ase_map(embeddings, "embeddings", None, "mask")?;
    let (q, qs) = arrays::f32_array(query, "query", 1)?;
    check_dim(&map, qs[0], "query", "embeddings")?;
    if !(0..map.rotations as i64).contains(&rotation) {
        return Err(bad(
            "rotation",
            format!("{rotation} is outside 0..{}", map.rotations),
        ));
    }
    let n = map.resolution;
    let d = py.detach(|| seespot_ssr::correspond::distance_map(&map, &q, rotation as usize));
    let a = Array2::from_shape_vec((n, n), d).map_err(|e| bad("embeddings", e))?;
    Ok(a.into_pyarray(py))
}
