"""Every place a lookalike command mixes the CPU and the GPU, in one run on a GPU.

Runs ``lookalike ARGS... --device cuda`` with the gate that keeps unverified kinds of run on the
CPU (``jobs.run.run_device``) opened, and with every mix of devices repaired on the spot and
recorded: a torch op given tensors on both (``TorchFunctionMode``: the CPU tensors are moved to
the GPU and the op run again), ``.numpy()`` of a GPU tensor (taken from a CPU copy), and a CUDA
launch given a CPU tensor (moved). So a kind of run that has never been on a GPU lists all its
sites in one call instead of failing at the first. Prints the sites, most frequent first, each
with its innermost lookalike frames; exit 0 where there were none and the run succeeded.

    python3 bench/gpu_probe.py cards shrub.glb -o /tmp/probe --iterations 20
    python3 bench/gpu_probe.py --foliage shrub /tmp/shrub.glb   # writes a generated sample first
"""

from __future__ import annotations

import collections
import sys
import traceback

import torch
from torch.overrides import TorchFunctionMode

SITES: collections.Counter = collections.Counter()


def where() -> str:
    frames = [f for f in traceback.extract_stack()[:-2] if "/lookalike/" in f.filename]
    return " <- ".join(f"{f.filename.split('/lookalike/')[-1]}:{f.lineno}:{f.name}" for f in frames[-4:][::-1])


def on_gpu(value):
    if isinstance(value, torch.Tensor):
        return value.cuda() if not value.is_cuda and value.dim() > 0 else value
    if isinstance(value, (list, tuple)):
        return type(value)(on_gpu(v) for v in value)
    if isinstance(value, dict):
        return {k: on_gpu(v) for k, v in value.items()}
    return value


class Repairing(TorchFunctionMode):
    """Runs each torch op; where it fails for mixed devices, records the site and repairs it."""

    def __torch_function__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        try:
            return func(*args, **kwargs)
        except (RuntimeError, TypeError) as e:
            name, message = getattr(func, "__name__", str(func)), str(e)
            if "numpy" in message and "cuda" in message:
                SITES[f"numpy() of a GPU tensor: {where()}"] += 1
                return func(*[a.cpu() if isinstance(a, torch.Tensor) else a for a in args], **kwargs)
            if "device" not in message:
                raise
            SITES[f"{name} on two devices: {where()}"] += 1
            return func(*on_gpu(args), **on_gpu(kwargs))


def open_the_gate() -> None:
    """Every kind of run on the GPU, and every CUDA launch checked for CPU tensors."""
    from lookalike import devices
    from lookalike.jobs import run

    run.run_device = lambda app, name, moving, reference: devices.resolve_device(name)
    launch = devices.launch

    def checked(kernel, count, *args):
        if any(isinstance(a, torch.Tensor) and not a.is_cuda for a in args):
            SITES[f"a CPU tensor in the launch of {getattr(kernel, '__name__', kernel)}: {where()}"] += 1
            args = tuple(on_gpu(a) for a in args)
        return launch(kernel, count, *args)

    devices.launch = checked
    for module in list(sys.modules.values()):  # the kernels' modules import launch by name
        if getattr(module, "__name__", "").startswith("lookalike.") and getattr(module, "launch", None) is launch:
            module.launch = checked


def main(argv: list[str]) -> int:
    if argv[:1] == ["--foliage"]:
        from lookalike.io import save
        from lookalike.samples.foliage import FOLIAGE

        save(FOLIAGE[argv[1]](), argv[2])
        return 0
    import importlib
    import pkgutil

    import lookalike
    for info in pkgutil.walk_packages(lookalike.__path__, "lookalike."):  # every kernel module, before patching
        if info.name.endswith("_cuda"):
            importlib.import_module(info.name)
    open_the_gate()
    from lookalike.cli import main as cli

    with Repairing():
        status = cli([*argv, "--device", "cuda"])
    print(f"gpu probe: lookalike {' '.join(argv)}: exit {status}, {len(SITES)} sites mixing devices")
    for site, count in SITES.most_common():
        print(f"  {count:6d}  {site}")
    return 0 if status == 0 and not SITES else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
