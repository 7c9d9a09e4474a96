//! Helpers the unit tests share.

/// How far `fast` is from the reference `slow`, and on what scale: the
/// largest absolute difference between them, element by element, and the
/// largest magnitude in `slow`.
pub(crate) fn worst_and_scale(fast: &[f32], slow: &[f32]) -> (f32, f32) {
    let scale = slow.iter().fold(0.0f32, |a, v| a.max(v.abs()));
    let worst = fast
        .iter()
        .zip(slow)
        .fold(0.0f32, |a, (p, q)| a.max((p - q).abs()));
    (worst, scale)
}
