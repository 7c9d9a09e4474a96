"""The numpy + scipy peer of seespot's Correspond benchmark (`seespot bench ssr`).

Does the work of one reference Correspond step
(`seespot_ssr::correspond::bench::correspond_step_cells`) on ASE maps of the
same shape, written the straightforward way: M = 3 live ASE maps of
R x H x W x D (R = 16, D = 64) and, per policy, N = 2 demo maps with one
demonstrated action each. For every (policy, demo) pair: Match (squared L2 of
the demo action's embedding to every live action, each rotation's map
smoothed with a Gaussian of 6 mm (scipy.ndimage.gaussian_filter with its
defaults), argmin), then Verify (the matched live embedding against the demo
map at the demo action's rotation, in the window of +/- 3 cm around the
demonstrated pixel, smoothed with wrap-around edges, argmin)
and C, the squared pixel distance in 2 mm pixels. `--sigma 0` times the
unsmoothed variant.

Squared norms are computed once per map outside the timed region (seespot
computes its actions' norms inside its timed step), so the peer times only
its matrix products, smoothing and argmins. Prints one JSON object.
"""
import argparse
import json
import os
import time

import numpy as np
import scipy
from scipy.ndimage import gaussian_filter


def random_map(rng, r, h, d):
    # Uniform in [0, 1) like post-ReLU features.
    return rng.random((r, h, h, d), dtype=np.float32)


def nearest(flat, norms, q, shape=None, sigma=None):
    d2 = norms - 2.0 * (flat @ q) + float(q @ q)
    if sigma:
        d2 = d2.reshape(shape)
        # scipy's defaults, as the reference: reflected edges, truncate 4 sigma.
        d2 = np.stack([gaussian_filter(p, sigma) for p in d2])
        d2 = d2.reshape(-1)
    i = int(np.argmin(d2))
    return i, float(d2[i])


def step(live, demos, actions, sigma=None, half_window=None):
    out = []
    for m in range(len(live)):
        flat, norms, shape = live[m]
        r, h, w = shape
        plane = h * w
        for (dflat, dnorms), a in zip(demos[m], actions[m]):
            q = dflat[a]
            i, d2 = nearest(flat, norms, q, shape, sigma)
            rot = a // plane
            ay, ax = divmod(a % plane, w)
            lo, hi = rot * plane, (rot + 1) * plane
            e = flat[i]
            y0, y1 = max(ay - half_window, 0), min(ay + half_window, h - 1)
            x0, x1 = max(ax - half_window, 0), min(ax + half_window, w - 1)
            # The window alone, smoothed with wrap-around edges (the reference).
            feats = dflat[lo:hi].reshape(h, w, -1)[y0:y1 + 1, x0:x1 + 1]
            pn = dnorms[lo:hi].reshape(h, w)[y0:y1 + 1, x0:x1 + 1]
            win = pn - 2.0 * (feats @ e) + float(e @ e)
            if sigma:
                win = gaussian_filter(win, sigma, mode="wrap")
            by, bx = np.unravel_index(int(np.argmin(win)), win.shape)
            by, bx = by + y0, bx + x0
            scale = (0.448 / h) / 0.002
            out.append((d2, float(((ay - by) ** 2 + (ax - bx) ** 2) * scale * scale)))
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--resolution", type=int, default=224)
    p.add_argument("--iterations", type=int, default=5)
    p.add_argument("--sigma", type=float, default=None,
                   help="smoothing sigma in pixels (default: 6 mm at this resolution)")
    args = p.parse_args()
    pixel = 0.448 / args.resolution
    sigma = 0.006 / pixel if args.sigma is None else args.sigma
    half_window = round(0.03 / pixel)
    rng = np.random.default_rng(0x5EE59071)
    r, d, h = 16, 64, args.resolution
    n_actions = r * h * h
    live, demos, actions = [], [], []
    for _ in range(3):
        f = random_map(rng, r, h, d).reshape(-1, d)
        live.append((f, np.einsum("ij,ij->i", f, f), (r, h, h)))
        ds, acts = [], []
        for _ in range(2):
            g = random_map(rng, r, h, d).reshape(-1, d)
            ds.append((g, np.einsum("ij,ij->i", g, g)))
            acts.append(int(rng.integers(n_actions)))
        demos.append(ds)
        actions.append(acts)
    step(live, demos, actions, sigma, half_window)  # warm-up
    times = []
    for _ in range(args.iterations):
        t = time.perf_counter()
        step(live, demos, actions, sigma, half_window)
        times.append((time.perf_counter() - t) * 1e3)
    times.sort()
    print(json.dumps({
        "peer": "numpy+scipy",
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS", "default"),
        "resolution": h,
        "iterations": len(times),
        "sigma_px": sigma,
        "half_window_px": half_window,
        "correspond_ms": times[len(times) // 2],
        "correspond_min_ms": times[0],
    }))


if __name__ == "__main__":
    main()
