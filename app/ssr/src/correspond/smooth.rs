//! Gaussian smoothing of the per-rotation distance maps (the reference code
//! smoothed both the match and the rematch maps with sigma 3 px).

/// Gaussian smoothing of an `n x n` row-major map in place, `sigma` in pixels.
///
/// Normalized convolution: entries that are not finite (masked actions,
/// `f32::INFINITY`) stay as they are and take no part in their neighbours'
/// averages, and the kernel is renormalized over the finite entries it covers
/// (also at the borders), so an infinity never spreads. Separable, kernel radius
/// `ceil(3 sigma)`: `O(n^2 * sigma)`. `sigma <= 0` or non-finite does nothing.
pub fn smooth(map: &mut [f32], n: usize, sigma: f32) {
    assert_eq!(map.len(), n * n, "smooth: map is not {n} x {n}");
    let finite: Vec<bool> = map.iter().map(|v| v.is_finite()).collect();
    if let Some(w) = smoothed_weights(&finite, n, sigma) {
        smooth_with_weights(map, n, sigma, &w);
    }
}

/// The Gaussian kernel of [`smooth`] (radius `ceil(3 sigma)`), or `None`
/// when `sigma` smooths nothing.
fn kernel(sigma: f32) -> Option<(usize, Vec<f32>)> {
    if !(sigma > 0.0 && sigma.is_finite()) {
        return None;
    }
    let radius = (3.0 * sigma).ceil() as usize;
    let k = (0..=2 * radius)
        .map(|i| {
            let d = i as f32 - radius as f32;
            (-0.5 * d * d / (sigma * sigma)).exp()
        })
        .collect();
    Some((radius, k))
}

/// Separable convolution of an `n x n` map with `kernel` (zero outside).
fn convolve(src: &[f32], n: usize, radius: usize, kernel: &[f32]) -> Vec<f32> {
    // Horizontal pass.
    let mut h = vec![0.0f32; n * n];
    for y in 0..n {
        let (row, out) = (&src[y * n..(y + 1) * n], &mut h[y * n..(y + 1) * n]);
        for (k, &g) in kernel.iter().enumerate() {
            // Output x reads input x + k - radius.
            let lo = radius.saturating_sub(k);
            let hi = (n + radius).saturating_sub(k).min(n);
            for x in lo..hi {
                out[x] += g * row[x + k - radius];
            }
        }
    }
    // Vertical pass, rows contiguous in the inner loop.
    let mut v = vec![0.0f32; n * n];
    for y in 0..n {
        let out = &mut v[y * n..(y + 1) * n];
        for (k, &g) in kernel.iter().enumerate() {
            let s = y + k;
            if s < radius || s - radius >= n {
                continue;
            }
            let s = s - radius;
            for (o, i) in out.iter_mut().zip(&h[s * n..(s + 1) * n]) {
                *o += g * i;
            }
        }
    }
    v
}

/// The normalizer of [`smooth`] for maps whose finite entries are `finite`
/// (`n x n`): the kernel summed over them. It depends on the mask alone, so
/// maps with one mask share it ([`smooth_with_weights`]). `None` when `sigma`
/// smooths nothing.
pub fn smoothed_weights(finite: &[bool], n: usize, sigma: f32) -> Option<Vec<f32>> {
    let (radius, k) = kernel(sigma)?;
    let w: Vec<f32> = finite.iter().map(|&f| if f { 1.0 } else { 0.0 }).collect();
    Some(convolve(&w, n, radius, &k))
}

/// [`smooth`] with the normalizer `weights` of the map's mask
/// ([`smoothed_weights`]): the same result, without recomputing it.
pub fn smooth_with_weights(map: &mut [f32], n: usize, sigma: f32, weights: &[f32]) {
    assert_eq!(map.len(), n * n, "smooth: map is not {n} x {n}");
    assert_eq!(weights.len(), n * n, "smooth: weights are not {n} x {n}");
    let Some((radius, k)) = kernel(sigma) else {
        return;
    };
    // Values with masked entries zeroed.
    let val: Vec<f32> = map
        .iter()
        .map(|&v| if v.is_finite() { v } else { 0.0 })
        .collect();
    let sv = convolve(&val, n, radius, &k);
    for ((m, v), w) in map.iter_mut().zip(sv).zip(weights) {
        if m.is_finite() {
            *m = v / w;
        }
    }
}
