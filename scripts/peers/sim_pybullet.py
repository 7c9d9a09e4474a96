"""The PyBullet peer of `seespot bench sim`: one drop-settle-render action.

The same world as seespot's: a table and four 5 cm cubes over a 44.8 cm
workspace; an action drops a random block from 20 cm at a random orientation
over the workspace (inset 10 cm), steps the physics at 240 Hz until every
block has been still (linear speed <= 5 mm/s, angular <= 0.05 rad/s) for 4
steps in a row or 2 s have passed, then renders a top-down H x H heightmap
(PyBullet's CPU renderer, depth turned into heights). Prints one JSON object.
"""
import argparse
import json
import math
import time

import numpy as np
import pybullet as p

WORKSPACE = 0.448
INSET = 0.1
BLOCK = 0.05
HZ = 240.0
CAM_H = 1.0


def make_world(rng):
    cid = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81)
    p.setTimeStep(1.0 / HZ)
    table = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.5, 0.5, 0.01])
    p.createMultiBody(0, table, basePosition=[0, 0, -0.01])
    box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[BLOCK / 2] * 3)
    vis = p.createVisualShape(p.GEOM_BOX, halfExtents=[BLOCK / 2] * 3)
    lim = WORKSPACE / 2 - INSET
    blocks = []
    for i in range(4):
        pos = [rng.uniform(-lim, lim), rng.uniform(-lim, lim), BLOCK / 2 + 0.06 * i]
        blocks.append(p.createMultiBody(0.1, box, vis, basePosition=pos))
    return cid, blocks


def settle(blocks):
    calm = 0
    for _ in range(int(2.0 * HZ)):
        p.stepSimulation()
        moving = False
        for b in blocks:
            lin, ang = p.getBaseVelocity(b)
            if math.hypot(*lin) > 0.005 or math.hypot(*ang) > 0.05:
                moving = True
                break
        calm = 0 if moving else calm + 1
        if calm >= 4:
            return


def render(h):
    view = p.computeViewMatrix([0, 0, CAM_H], [0, 0, 0], [0, 1, 0])
    near, far = 0.5, CAM_H + 0.1
    fov = 2 * math.degrees(math.atan(WORKSPACE / 2 / CAM_H))
    proj = p.computeProjectionMatrixFOV(fov, 1.0, near, far)
    _, _, rgb, depth, _ = p.getCameraImage(h, h, view, proj, renderer=p.ER_TINY_RENDERER)
    depth = np.asarray(depth, dtype=np.float32).reshape(h, h)
    z = far * near / (far - (far - near) * depth)
    return CAM_H - z, np.asarray(rgb, dtype=np.uint8).reshape(h, h, 4)


def drop(blocks, rng):
    lim = WORKSPACE / 2 - INSET
    b = blocks[rng.integers(len(blocks))]
    axis = rng.uniform(-1, 1, 3)
    axis /= np.linalg.norm(axis) or 1.0
    q = p.getQuaternionFromAxisAngle(axis.tolist(), rng.uniform(0, 2 * math.pi))
    p.resetBasePositionAndOrientation(b, [rng.uniform(-lim, lim), rng.uniform(-lim, lim), 0.2], q)
    p.resetBaseVelocity(b, [0, 0, 0], [0, 0, 0])
    settle(blocks)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=int, default=224)
    ap.add_argument("--actions", type=int, default=100)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    _, blocks = make_world(rng)
    settle(blocks)
    checksum = 0.0
    t = time.perf_counter()
    for _ in range(args.actions):
        drop(blocks, rng)
        hm, _ = render(args.resolution)
        checksum += float(hm[args.resolution // 2, args.resolution // 2])
    s = time.perf_counter() - t
    renders = max(args.actions, 50)
    t = time.perf_counter()
    for _ in range(renders):
        hm, _ = render(args.resolution)
    r = time.perf_counter() - t
    print(json.dumps({
        "peer": "pybullet",
        "pybullet_api": p.getAPIVersion(),
        "resolution": args.resolution,
        "actions": args.actions,
        "ms_per_action": 1e3 * s / args.actions,
        "render_ms": 1e3 * r / renders,
        "checksum": checksum,
    }))


if __name__ == "__main__":
    main()
