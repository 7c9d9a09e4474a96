//! What an embedding sees: per-pixel ASEs (D-dimensional) shown as colours, by
//! projecting them on their first three principal components. The components
//! are computed jointly over the live and the demo planes, so the same colour
//! means the same embedding in both pictures.

/// RGB8 images (`H x W x 3`, row-major) of `planes`, each `H x W x dim`
/// features: the joint first three principal components, each scaled from its
/// 1st to its 99th percentile over all planes to 0..=255. Non-finite features
/// are shown black.
pub fn pca_rgb(planes: &[&[f32]], dim: usize) -> Vec<Vec<u8>> {
    use rayon::prelude::*;
    /// Rows per parallel work item (fixed, so sums do not depend on threads).
    const CHUNK: usize = 1024;
    let finite_rows: Vec<&[f32]> = planes
        .iter()
        .flat_map(|p| p.chunks_exact(dim))
        .filter(|f| f.iter().all(|v| v.is_finite()))
        .collect();
    let n = finite_rows.len().max(1) as f64;
    let sums: Vec<Vec<f64>> = finite_rows
        .par_chunks(CHUNK)
        .map(|c| {
            let mut s = vec![0.0f64; dim];
            for f in c {
                for (a, v) in s.iter_mut().zip(*f) {
                    *a += *v as f64;
                }
            }
            s
        })
        .collect();
    let mut mean = vec![0.0f64; dim];
    for s in &sums {
        for (m, v) in mean.iter_mut().zip(s) {
            *m += v;
        }
    }
    for m in &mut mean {
        *m /= n;
    }
    // Upper triangle of the scatter matrix, per chunk, then summed in order.
    let parts: Vec<Vec<f64>> = finite_rows
        .par_chunks(CHUNK)
        .map(|rows| seespot_policy::simd::dispatch!(covariance_part(rows, &mean, dim)))
        .collect();
    let mut cov = vec![0.0f64; dim * dim];
    for p in &parts {
        for (a, v) in cov.iter_mut().zip(p) {
            *a += v;
        }
    }
    for i in 0..dim {
        for j in i..dim {
            cov[i * dim + j] /= n;
        }
        for j in 0..i {
            cov[i * dim + j] = cov[j * dim + i];
        }
    }
    let components = top_eigenvectors(&mut cov, dim, 3);
    let project = |f: &[f32]| -> [f64; 3] {
        let mut out = [0.0f64; 3];
        for (k, o) in out.iter_mut().enumerate() {
            *o = f
                .iter()
                .zip(&mean)
                .zip(&components[k])
                .map(|((v, m), c)| (*v as f64 - m) * c)
                .sum();
        }
        out
    };
    // Every finite pixel's three components, in plane order.
    let projected: Vec<[f64; 3]> = finite_rows.par_iter().map(|f| project(f)).collect();
    // Per component, the 1st and 99th percentiles over every finite pixel.
    let ranges: Vec<(f64, f64)> = (0..3)
        .map(|k| {
            let mut v: Vec<f64> = projected.iter().map(|p| p[k]).collect();
            if v.is_empty() {
                return (0.0, 1.0);
            }
            v.sort_by(f64::total_cmp);
            let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
            let (lo, hi) = (at(0.01), at(0.99));
            (lo, if hi > lo { hi } else { lo + 1.0 })
        })
        .collect();
    let mut next = projected.iter();
    planes
        .iter()
        .map(|p| {
            let mut out = Vec::with_capacity(p.len() / dim * 3);
            for f in p.chunks_exact(dim) {
                let finite = f.iter().all(|v| v.is_finite());
                let proj = if finite { next.next() } else { None };
                for (k, (lo, hi)) in ranges.iter().enumerate() {
                    out.push(match proj {
                        Some(c) => ((c[k] - lo) / (hi - lo) * 255.0).clamp(0.0, 255.0) as u8,
                        None => 0,
                    });
                }
            }
            out
        })
        .collect()
}

/// The `k` leading eigenvectors of the symmetric `dim x dim` matrix `m`, by
/// power iteration with deflation (`m` is deflated in place).
/// The upper triangle of `sum (f - mean)(f - mean)^T` over `rows`
/// (`dim x dim`, row-major; the lower triangle is left zero).
#[inline(always)]
fn covariance_part(rows: &[&[f32]], mean: &[f64], dim: usize) -> Vec<f64> {
    let mut acc = vec![0.0f64; dim * dim];
    let mut c = vec![0.0f64; dim];
    for f in rows {
        for ((x, v), m) in c.iter_mut().zip(*f).zip(mean) {
            *x = *v as f64 - m;
        }
        for i in 0..dim {
            let ci = c[i];
            for (a, cj) in acc[i * dim + i..(i + 1) * dim].iter_mut().zip(&c[i..]) {
                *a += ci * cj;
            }
        }
    }
    acc
}

/// `m v` for a symmetric `dim x dim` matrix `m`: each entry summed over `j`
/// in order, as `sum_j m[i][j] v[j]`, but read by rows (`m[j][i]`), so the
/// entries are computed side by side in vector lanes.
#[inline(always)]
fn symmetric_times(m: &[f64], v: &[f64], dim: usize) -> Vec<f64> {
    let mut w = vec![0.0f64; dim];
    for (row, &vj) in m.chunks_exact(dim).zip(v) {
        for (a, mji) in w.iter_mut().zip(row) {
            *a += mji * vj;
        }
    }
    w
}

fn top_eigenvectors(m: &mut [f64], dim: usize, k: usize) -> Vec<Vec<f64>> {
    let mut out = Vec::with_capacity(k);
    for c in 0..k {
        // A deterministic start that is not orthogonal to a typical eigenvector.
        let mut v: Vec<f64> = (0..dim).map(|i| 1.0 + ((i + c) % 7) as f64 * 0.1).collect();
        let mut lambda = 0.0;
        for _ in 0..200 {
            let w = seespot_policy::simd::dispatch!(symmetric_times(m, &v, dim));
            let norm = w.iter().map(|x| x * x).sum::<f64>().sqrt();
            if norm < 1e-30 {
                break;
            }
            lambda = norm;
            v = w.into_iter().map(|x| x / norm).collect();
        }
        // Deflate, keeping `m` exactly symmetric (`symmetric_times` reads it
        // by rows).
        for i in 0..dim {
            for j in i..dim {
                let t = m[i * dim + j] - lambda * v[i] * v[j];
                m[i * dim + j] = t;
                m[j * dim + i] = t;
            }
        }
        out.push(v);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_component_follows_the_largest_variation() {
        // 2 planes of 4 pixels, D = 3: the features vary along axis 1 only.
        let a = [0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 2.0, 1.0, 0.0, 3.0, 1.0];
        let b = [0.0, 4.0, 1.0, 0.0, 5.0, 1.0, 0.0, 6.0, 1.0, 0.0, 7.0, 1.0];
        let rgb = pca_rgb(&[&a, &b], 3);
        assert_eq!(rgb.len(), 2);
        assert_eq!(rgb[0].len(), 4 * 3);
        // Red (component 1) is monotone in the varying feature, across planes.
        let red: Vec<u8> = rgb.iter().flat_map(|p| p.chunks(3).map(|c| c[0])).collect();
        let up = red.windows(2).all(|w| w[0] <= w[1]);
        let down = red.windows(2).all(|w| w[0] >= w[1]);
        assert!(up || down, "{red:?}");
        assert_ne!(red[0], red[7]);
    }

    #[test]
    fn non_finite_features_are_black() {
        let a = [1.0, f32::NAN, 2.0, 3.0];
        let rgb = pca_rgb(&[&a], 2);
        assert_eq!(&rgb[0][..3], &[0, 0, 0]);
    }
}
