# %% [markdown]
# # The leave-one-out evaluation on Ray
#
# `seespot.dist.evaluate` runs trials on Ray actors (one policy set per actor)
# and appends each record to `<out>/trials/<method>/<task>.jsonl.gz`, the file
# `seespot eval` writes: rerunning resumes, and `seespot eval` with the same
# arguments then only writes the report. On one machine it starts Ray on
# 127.0.0.1 (no dashboard, no usage statistics); pass `address=` for a cluster.
#
#     .venv-py/bin/python python/examples/ray_evaluation.py
#     cargo run --release -p seespot -- eval --method oracle --trials 4 --out runs/ray   # the report
#
# The same from the shell: `python -m seespot.dist --method oracle --trials 4 --workers 2 --out runs/ray`.

# %%
import sys

try:
    from seespot import dist
except ModuleNotFoundError as e:
    sys.exit(
        f"this example needs the seespot package and Ray, and this Python "
        f"({sys.executable}) has no module {e.name!r}. From the repository root, either\n"
        f"  scripts/test-python   # makes .venv-py with all of them (and runs the package's tests)\n"
        f"  .venv-py/bin/python python/examples/ray_evaluation.py\n"
        f"or\n"
        f"  python3 -m venv .venv && .venv/bin/pip install '.[ray]'   # compiles the Rust core\n"
        f"  .venv/bin/python python/examples/ray_evaluation.py"
    )

result = dist.evaluate(["oracle", "random"], seed=1, trials=4, out_dir="runs/ray", num_workers=2)
for (method, task), records in result.items():
    ok = sum(r["success"] for r in records)
    print(f"{method:>7} {task:>15}: success {ok}/{len(records)}")
