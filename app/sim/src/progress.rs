//! The progress measure P(s) of docs/design.md §2, computed from block poses.
//!
//! Tolerances are the reference implementation's, kept as named constants.

use crate::world::BlockPose;

/// A block on top of another lies within this horizontal distance of it, metres.
pub const STACK_XY_TOLERANCE: f32 = 0.03;
/// ... at least this much lower (the next block down), metres.
pub const STACK_MIN_DROP: f32 = 0.03;
/// ... and at most this far away in 3-D, metres.
pub const STACK_MAX_DISTANCE: f32 = 0.06;
/// Blocks of a row lie within this distance of the fitted line, metres.
pub const ROW_LINE_TOLERANCE: f32 = 0.02;
/// Blocks of a row lie within this height band, metres.
pub const ROW_HEIGHT_TOLERANCE: f32 = 0.02;
/// Neighbours along a row are at least this far apart, centre to centre, metres.
pub const ROW_MIN_SPACING: f32 = 0.05;
/// Neighbours along a row are at most this far apart, centre to centre, metres.
pub const ROW_MAX_SPACING: f32 = 0.10;

/// Whether block `upper` rests on block `lower` by the stack rule.
pub fn is_on(upper: &BlockPose, lower: &BlockPose) -> bool {
    let [ux, uy, uz] = upper.position;
    let [lx, ly, lz] = lower.position;
    let dxy = ((ux - lx).powi(2) + (uy - ly).powi(2)).sqrt();
    let d3 = (dxy * dxy + (uz - lz).powi(2)).sqrt();
    dxy <= STACK_XY_TOLERANCE && uz - lz >= STACK_MIN_DROP && d3 <= STACK_MAX_DISTANCE
}

/// Height of the tallest tower, in blocks (>= 1 when any block exists).
///
/// From each block, walk down: the next block is the highest one it rests on
/// ([`is_on`]). The reference starts from the highest block only; seespot takes the
/// maximum over all starting blocks, which is the same for a single tower and
/// does not miss a tall tower beside a higher tilted block.
pub fn stack_height(blocks: &[BlockPose]) -> usize {
    (0..blocks.len())
        .map(|start| tower_below(blocks, start).len())
        .max()
        .unwrap_or(0)
}

/// The chain of block indices from `top` walking down, `top` first.
pub fn tower_below(blocks: &[BlockPose], top: usize) -> Vec<usize> {
    let mut chain = vec![top];
    let mut current = top;
    loop {
        let next = (0..blocks.len())
            .filter(|&j| !chain.contains(&j) && is_on(&blocks[current], &blocks[j]))
            .max_by(|&a, &b| blocks[a].position[2].total_cmp(&blocks[b].position[2]));
        match next {
            Some(j) => {
                chain.push(j);
                current = j;
            }
            None => return chain,
        }
    }
}

/// Whether the blocks at `idx` (two or more) form a row by the rules of docs/design.md §2.
pub fn is_row(blocks: &[BlockPose], idx: &[usize]) -> bool {
    if idx.len() < 2 {
        return idx.len() == 1;
    }
    let pts: Vec<[f32; 3]> = idx.iter().map(|&i| blocks[i].position).collect();
    let (zmin, zmax) = pts
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), p| (a.min(p[2]), b.max(p[2])));
    if zmax - zmin > ROW_HEIGHT_TOLERANCE {
        return false;
    }
    // Fit a line through the x,y points: principal axis of their covariance.
    let n = pts.len() as f32;
    let (cx, cy) = (
        pts.iter().map(|p| p[0]).sum::<f32>() / n,
        pts.iter().map(|p| p[1]).sum::<f32>() / n,
    );
    let (mut sxx, mut syy, mut sxy) = (0.0f32, 0.0f32, 0.0f32);
    for p in &pts {
        let (dx, dy) = (p[0] - cx, p[1] - cy);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let (ux, uy) = (angle.cos(), angle.sin());
    let mut along = Vec::with_capacity(pts.len());
    for p in &pts {
        let (dx, dy) = (p[0] - cx, p[1] - cy);
        let off = (-uy * dx + ux * dy).abs();
        if off > ROW_LINE_TOLERANCE {
            return false;
        }
        along.push(ux * dx + uy * dy);
    }
    along.sort_by(f32::total_cmp);
    along.windows(2).all(|w| {
        let gap = w[1] - w[0];
        (ROW_MIN_SPACING..=ROW_MAX_SPACING).contains(&gap)
    })
}

/// Size of the largest subset of blocks that forms a row (>= 1 when any block exists).
pub fn longest_row(blocks: &[BlockPose]) -> usize {
    best_row(blocks).len()
}

/// The largest row (indices), first found in subset order among equals.
pub fn best_row(blocks: &[BlockPose]) -> Vec<usize> {
    let n = blocks.len();
    let mut best: Vec<usize> = if n > 0 { vec![0] } else { vec![] };
    for mask in 1u32..(1 << n) {
        let idx: Vec<usize> = (0..n).filter(|i| mask & (1 << i) != 0).collect();
        if idx.len() > best.len() && is_row(blocks, &idx) {
            best = idx;
        }
    }
    best
}

/// All (upper, lower) pairs where `upper` rests on `lower`.
pub fn stacked_pairs(blocks: &[BlockPose]) -> Vec<(usize, usize)> {
    let mut pairs = Vec::new();
    for u in 0..blocks.len() {
        for l in 0..blocks.len() {
            if u != l && is_on(&blocks[u], &blocks[l]) {
                pairs.push((u, l));
            }
        }
    }
    pairs
}

/// Progress of the vertical square (two 2-block towers side by side), docs/design.md §2:
/// 4 if two 2-block stacks have bottoms that form a row; 3 if one 2-block stack's
/// bottom forms a row with another block; 2 if there is a 2-block stack or a
/// 2-block row; else 1.
pub fn vertical_square(blocks: &[BlockPose]) -> u8 {
    let pairs = stacked_pairs(blocks);
    for (i, &(u1, l1)) in pairs.iter().enumerate() {
        for &(u2, l2) in &pairs[i + 1..] {
            let disjoint = u1 != u2 && u1 != l2 && l1 != u2 && l1 != l2;
            if disjoint && is_row(blocks, &[l1, l2]) {
                return 4;
            }
        }
    }
    for &(u, l) in &pairs {
        for other in 0..blocks.len() {
            if other != u && other != l && is_row(blocks, &[l, other]) {
                return 3;
            }
        }
    }
    if !pairs.is_empty() || longest_row(blocks) >= 2 {
        return 2;
    }
    1
}
