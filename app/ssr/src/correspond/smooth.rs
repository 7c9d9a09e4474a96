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
    if !(sigma > 0.0 && sigma.is_finite()) || n == 0 {
        return;
    }
    let radius = (3.0 * sigma).ceil() as usize;
    let kernel: Vec<f32> = (0..=2 * radius)
        .map(|i| {
            let d = i as f32 - radius as f32;
            (-0.5 * d * d / (sigma * sigma)).exp()
        })
        .collect();
    // Values with masked entries zeroed, and the mask as weights.
    let val: Vec<f32> = map
        .iter()
        .map(|&v| if v.is_finite() { v } else { 0.0 })
        .collect();
    let wgt: Vec<f32> = map
        .iter()
        .map(|&v| if v.is_finite() { 1.0 } else { 0.0 })
        .collect();
    // Horizontal pass.
    let mut hv = vec![0.0f32; n * n];
    let mut hw = vec![0.0f32; n * n];
    for y in 0..n {
        let (vr, wr) = (&val[y * n..(y + 1) * n], &wgt[y * n..(y + 1) * n]);
        let (ov, ow) = (&mut hv[y * n..(y + 1) * n], &mut hw[y * n..(y + 1) * n]);
        for (k, &g) in kernel.iter().enumerate() {
            // Output x reads input x + k - radius.
            let lo = radius.saturating_sub(k);
            let hi = (n + radius).saturating_sub(k).min(n);
            for x in lo..hi {
                let s = x + k - radius;
                ov[x] += g * vr[s];
                ow[x] += g * wr[s];
            }
        }
    }
    // Vertical pass, rows contiguous in the inner loop.
    let mut sv = vec![0.0f32; n * n];
    let mut sw = vec![0.0f32; n * n];
    for y in 0..n {
        let (ov, ow) = (&mut sv[y * n..(y + 1) * n], &mut sw[y * n..(y + 1) * n]);
        for (k, &g) in kernel.iter().enumerate() {
            let s = y + k;
            if s < radius || s - radius >= n {
                continue;
            }
            let s = s - radius;
            for ((o, p), (iv, iw)) in ov
                .iter_mut()
                .zip(ow.iter_mut())
                .zip(hv[s * n..(s + 1) * n].iter().zip(&hw[s * n..(s + 1) * n]))
            {
                *o += g * iv;
                *p += g * iw;
            }
        }
    }
    for ((m, v), w) in map.iter_mut().zip(sv).zip(sw) {
        if m.is_finite() {
            *m = v / w;
        }
    }
}
