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
from seespot import dist

result = dist.evaluate(["oracle", "random"], seed=1, trials=4, out_dir="runs/ray", num_workers=2)
for (method, task), records in result.items():
    ok = sum(r["success"] for r in records)
    print(f"{method:>7} {task:>15}: success {ok}/{len(records)}")
