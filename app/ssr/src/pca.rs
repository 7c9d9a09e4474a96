//! What an embedding sees: per-pixel ASEs (D-dimensional) shown as colours, by
//! projecting them on their first three principal components. The components
//! are computed jointly over the live and the demo planes, so the same colour
//! means the same embedding in both pictures.

/// The principal components are fitted on every `FIT_STRIDE`-th finite pixel
/// (in plane order); every pixel is then projected on them. Neighbouring
/// pixels interpolate the same few cell embeddings, so a quarter of them
/// spans the same directions at a quarter of the cost of the scatter matrix
/// (the debugger draws this picture at every decision).
pub const FIT_STRIDE: usize = 4;

/// RGB8 images (`H x W x 3`, row-major) of `planes`, each `H x W x dim`
/// features: the joint first three principal components (fitted on every
/// [`FIT_STRIDE`]-th finite pixel), each scaled from its 1st to its 99th
/// percentile over all planes' finite pixels to 0..=255. Non-finite features
/// are shown black.
pub fn pca_rgb(planes: &[&[f32]], dim: usize) -> Vec<Vec<u8>> {
    use rayon::prelude::*;
    /// Rows per parallel work item (fixed, so sums do not depend on threads).
    const CHUNK: usize = 1024;
    let rows: Vec<&[f32]> = planes.iter().flat_map(|p| p.chunks_exact(dim)).collect();
    let finite: Vec<bool> = rows
        .par_iter()
        .map(|f| f.iter().all(|v| v.is_finite()))
        .collect();
    let fit_rows: Vec<&[f32]> = rows
        .iter()
        .zip(&finite)
        .filter(|(_, ok)| **ok)
        .map(|(f, _)| *f)
        .step_by(FIT_STRIDE)
        .collect();
    let n = fit_rows.len().max(1) as f64;
    let mut mean = vec![0.0f64; dim];
    for f in &fit_rows {
        for (m, v) in mean.iter_mut().zip(*f) {
            *m += *v as f64;
        }
    }
    for m in &mut mean {
        *m /= n;
    }
    // Upper triangle of the scatter matrix, per chunk, then summed in order.
    let parts: Vec<Vec<f64>> = fit_rows
        .par_chunks(CHUNK)
        .map(|rows| covariance_part_wide(rows, &mean, dim))
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
    let components = top_eigenvectors(&cov, dim, 3);
    // Projections in f32 (a picture needs no more): `f . c_k - mean . c_k`.
    let axes: Vec<Vec<f32>> = components
        .iter()
        .map(|c| c.iter().map(|v| *v as f32).collect())
        .collect();
    let offsets: Vec<f32> = components
        .iter()
        .map(|c| c.iter().zip(&mean).map(|(a, b)| a * b).sum::<f64>() as f32)
        .collect();
    let projected: Vec<[f32; 3]> = rows
        .par_chunks(CHUNK)
        .zip(finite.par_chunks(CHUNK))
        .flat_map_iter(|(rows, ok)| project_rows_wide(rows, ok, &axes, &offsets))
        .collect();
    // Per component, the 1st and 99th percentiles over every finite pixel.
    let ranges: Vec<(f32, f32)> = (0..3)
        .map(|k| {
            let mut v: Vec<f32> = projected
                .iter()
                .zip(&finite)
                .filter(|(_, ok)| **ok)
                .map(|(p, _)| p[k])
                .collect();
            if v.is_empty() {
                return (0.0, 1.0);
            }
            let mut at = |q: f64| {
                let i = ((v.len() - 1) as f64 * q).round() as usize;
                *v.select_nth_unstable_by(i, f32::total_cmp).1
            };
            let (lo, hi) = (at(0.01), at(0.99));
            (lo, if hi > lo { hi } else { lo + 1.0 })
        })
        .collect();
    let mut at = 0;
    planes
        .iter()
        .map(|p| {
            let count = p.len() / dim;
            let mut out = Vec::with_capacity(count * 3);
            for (c, ok) in projected[at..at + count]
                .iter()
                .zip(&finite[at..at + count])
            {
                for (k, (lo, hi)) in ranges.iter().enumerate() {
                    out.push(if *ok {
                        ((c[k] - lo) / (hi - lo) * 255.0).clamp(0.0, 255.0) as u8
                    } else {
                        0
                    });
                }
            }
            at += count;
            out
        })
        .collect()
}

seespot_policy::simd::kernel! {
    /// Each row's three projections `f . axes[k] - offsets[k]` (zeros where the
    /// row is not finite), summed in 16 lanes.
    fn project_rows_wide / project_rows(
        rows: &[&[f32]],
        ok: &[bool],
        axes: &[Vec<f32>],
        offsets: &[f32],
    ) -> Vec<[f32; 3]> {
        const LANES: usize = 16;
        // Plain loops rather than a closure, so the whole body is compiled for
        // the variant's instructions ([`seespot_policy::simd::kernel!`]).
        let mut projected = Vec::with_capacity(rows.len());
        for (f, &ok) in rows.iter().zip(ok) {
            let mut out = [0.0f32; 3];
            if ok {
                for (k, o) in out.iter_mut().enumerate() {
                    let mut acc = [0.0f32; LANES];
                    let (fc, ac) = (f.chunks_exact(LANES), axes[k].chunks_exact(LANES));
                    let (fr, ar) = (fc.remainder(), ac.remainder());
                    for (a, b) in fc.zip(ac) {
                        for l in 0..LANES {
                            acc[l] += a[l] * b[l];
                        }
                    }
                    let tail: f32 = fr.iter().zip(ar).map(|(a, b)| a * b).sum();
                    *o = acc.iter().sum::<f32>() + tail - offsets[k];
                }
            }
            projected.push(out);
        }
        projected
    }
}

seespot_policy::simd::kernel! {
    /// The upper triangle of `sum (f - mean)(f - mean)^T` over `rows`
    /// (`dim x dim`, row-major; the lower triangle is left zero).
    fn covariance_part_wide / covariance_part(
        rows: &[&[f32]],
        mean: &[f64],
        dim: usize,
    ) -> Vec<f64> {
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
}

/// The `k` eigenvectors of the symmetric `dim x dim` matrix `m` (row-major)
/// with the largest eigenvalues, largest first (nalgebra's symmetric
/// eigendecomposition). Each is turned so that its largest-magnitude entry is
/// positive, so the same matrix always gives the same colours. With fewer
/// than `k` dimensions the missing components are zero.
fn top_eigenvectors(m: &[f64], dim: usize, k: usize) -> Vec<Vec<f64>> {
    let eig = nalgebra::DMatrix::from_row_slice(dim, dim, m).symmetric_eigen();
    let mut order: Vec<usize> = (0..dim).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    order
        .into_iter()
        .take(k)
        .map(|i| {
            let v: Vec<f64> = eig.eigenvectors.column(i).iter().copied().collect();
            let largest = v
                .iter()
                .copied()
                .fold(0.0f64, |a, x| if x.abs() > a.abs() { x } else { a });
            let sign = if largest < 0.0 { -1.0 } else { 1.0 };
            v.into_iter().map(|x| sign * x).collect()
        })
        .chain(std::iter::repeat(vec![0.0; dim]))
        .take(k)
        .collect()
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
