"""The numpy + scipy peer of seespot's Correspond benchmark (`seespot bench ssr`).

Does the work `seespot_ssr::correspond::bench::correspond_step` does, on maps of
the same shape: M = 3 live ASE maps of R x H x W x D (R = 16, D = 64) and, per
policy, N = 2 demo maps with one demonstrated action each. For every (policy,
demo) pair: Match (the nearest live action to the demo action's embedding, by
squared L2 over all R x H x W actions), then Verify (the nearest demo action to
the matched live embedding, at the demo action's rotation) and C, the pixel
distance between the demonstrated action and that rematch. The smoothed
variant smooths each rotation's distance map with a Gaussian
(scipy.ndimage.gaussian_filter, sigma in pixels) before the argmin, as
seespot's `--smooth-sigma` does.

Squared norms are computed once per map outside the timed region (seespot's
AseMap carries them too), so both sides time the same work: one pass of
matrix products and argmins. Prints one JSON object.
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
        d2 = np.stack([gaussian_filter(p, sigma, mode="nearest") for p in d2])
        d2 = d2.reshape(-1)
    i = int(np.argmin(d2))
    return i, float(d2[i])


def step(live, demos, actions, sigma=None):
    out = []
    for m in range(len(live)):
        flat, norms, shape = live[m]
        r, h, w = shape
        plane = h * w
        for (dflat, dnorms), a in zip(demos[m], actions[m]):
            q = dflat[a]
            i, d2 = nearest(flat, norms, q, shape, sigma)
            rot = a // plane
            lo, hi = rot * plane, (rot + 1) * plane
            j, _ = nearest(dflat[lo:hi], dnorms[lo:hi], flat[i], (1, h, w), sigma)
            ay, ax = divmod(a % plane, w)
            by, bx = divmod(j, w)
            out.append((float(np.sqrt(max(d2, 0.0))), float(np.hypot(ay - by, ax - bx))))
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--resolution", type=int, default=224)
    p.add_argument("--iterations", type=int, default=5)
    p.add_argument("--sigma", type=float, default=3.0)
    args = p.parse_args()
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
    step(live, demos, actions)  # warm-up
    times = []
    for _ in range(args.iterations):
        t = time.perf_counter()
        step(live, demos, actions)
        times.append((time.perf_counter() - t) * 1e3)
    times.sort()
    smoothed = []
    for _ in range(max(1, args.iterations // 2)):
        t = time.perf_counter()
        step(live, demos, actions, sigma=args.sigma)
        smoothed.append((time.perf_counter() - t) * 1e3)
    smoothed.sort()
    print(json.dumps({
        "peer": "numpy+scipy",
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS", "default"),
        "resolution": h,
        "iterations": len(times),
        "correspond_ms": times[len(times) // 2],
        "correspond_min_ms": times[0],
        "correspond_smoothed_ms": smoothed[len(smoothed) // 2],
    }))


if __name__ == "__main__":
    main()
