"""Your network as See-SPOT-Run's embeddings, without exporting it
(docs/embeddings.md, "From PyTorch").

Wherever seespot takes ``embeddings`` (:class:`seespot.Ssr`,
:class:`seespot.Evaluator`, :func:`seespot.run_trial`, :func:`seespot.view`),
an item may be, in place of an ONNX file:

- a function ``scene -> features``: ``scene`` is the rotated scene
  ``float32[R, 4, 112, 112]`` (numpy), ``features`` anything
  ``numpy.asarray`` reads as ``float32[R, D, S, S]`` (S dividing 112);
- a ``torch.nn.Module`` with that forward (run in eval mode, without
  gradients, on the device of its parameters);
- a ``(grasp, place)`` pair of those, one per primitive.

seespot checks it as it checks a file (the same contract and refusals, on the
bare table at 16 rotations and at 1) and names it after the function or the
module's class (:func:`name_of`): ``ssr-ccd@mynet`` for ``MyNet``. Records say that such a
run was made with a function and cannot be replayed without it.
"""

from __future__ import annotations

import re
from typing import Any, Callable

import numpy as np


def _is_torch_module(obj: Any) -> bool:
    # torch is imported only if the object is one of its modules.
    return any(c.__module__.startswith("torch.nn") and c.__name__ == "Module" for c in type(obj).__mro__)


def as_function(obj: Any) -> Callable[[np.ndarray], Any]:
    """``obj`` as a function ``float32[R, 4, 112, 112] -> float32[R, D, S, S]``:
    a ``torch.nn.Module`` wrapped (eval mode, ``torch.inference_mode``, inputs
    moved to its parameters' device, outputs back to numpy), anything else
    callable as it is."""
    if _is_torch_module(obj):
        import torch

        module = obj.eval()
        device = next((p.device for p in module.parameters()), torch.device("cpu"))

        def run(scene: np.ndarray) -> np.ndarray:
            with torch.inference_mode():
                out = module(torch.from_numpy(scene).to(device))
            if not isinstance(out, torch.Tensor):
                raise TypeError(
                    f"{type(module).__name__}.forward returned {type(out).__name__}; "
                    "seespot takes one tensor float32[R, D, S, S]"
                )
            return out.detach().float().cpu().numpy()

        return run
    if not callable(obj):
        raise TypeError(f"embeddings: a {type(obj).__name__} is not callable")
    return obj


def name_of(obj: Any) -> str:
    """The name a function's runs and records carry: a module's class name,
    a function's ``__name__``, or both names of a ``(grasp, place)`` pair,
    with anything but letters, digits, ``-``, ``_`` and ``.`` made ``-``."""
    if isinstance(obj, tuple):
        return "-".join(name_of(f) for f in obj)
    raw = type(obj).__name__ if _is_torch_module(obj) else getattr(obj, "__name__", None) or type(obj).__name__
    name = re.sub(r"[^A-Za-z0-9_.-]", "-", raw).strip("-") or "function"
    return name[:64]
