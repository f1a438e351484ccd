"""Where the tensors of a run live, and how the compiled kernels reach the GPU.

A run names its device once (``render.device``: ``"auto"``, ``"cuda"`` or ``"cpu"``) and
``resolve_device`` turns the name into a ``torch.device``: ``"auto"`` is CUDA where torch sees a
GPU and numba-cuda (the ``[cuda]`` extra) imports, else the CPU. From there on the tensors carry
the device and every compiled kernel follows its inputs: an op whose tensors are on the GPU runs
the kernel's CUDA form (``*_cuda.py`` beside its Numba CPU form ``*_kernels.py``), with the same
structure, one GPU thread where the CPU form has one ``prange`` iteration, and the same code:
both forms call one per-element body, which ``device_function`` compiles for the GPU.

The CUDA kernels take torch's tensors as they are, without a copy, through
``__cuda_array_interface__`` (``kernel_array``), and run on torch's current stream (``launch``),
so that they order with torch's own kernels and need no synchronisation. ``numba.cuda`` is
imported on first use, never by ``import lookalike``, and nothing here sets an environment
variable.

The tests run the CUDA kernels where there is no GPU, in Numba's CUDA simulator, on CPU tensors:
``cuda_kernels_for_cpu_tensors`` makes the ops take the CUDA forms for CPU tensors too; nothing
but the tests uses it.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import sys
import types
from collections.abc import Iterator

from .errors import DeviceError

THREADS_PER_BLOCK = 128
"""GPU threads per block of every launch: a multiple of the warp, small enough that blocks of
kernels with many registers still fit several to a multiprocessor."""

CPU = "cpu"
"""The device name of the CPU (``torch.device`` takes it as it is)."""

_cuda_kernels_for_cpu_tensors = False
_device_functions: dict = {}
_launches = 0


def numba_cuda():
    """The ``numba.cuda`` module, imported on the first call; ``DeviceError`` where numba-cuda
    is not installed."""
    try:
        from numba import cuda
    except ImportError as e:
        raise DeviceError(f"numba-cuda is not installed ({e}); pip install -e \".[cuda]\" adds it") from None
    return cuda


def device_function(function):
    """The CUDA device function of the Numba CPU function ``function`` (an ``@njit`` one): its
    Python compiled for the GPU, every Numba CPU function it calls replaced by its device
    function too (made the same way, once each), and ``kernel_scatter.scatter_add`` by its
    atomic form.

    So one per-element body serves both forms of a kernel: the CPU kernel calls it in its
    ``prange`` loop, the CUDA kernel in each thread. In the simulator the device function runs
    the body's Python, so its callees must be simulated device functions too (the simulator's
    arrays reach no CPU function)."""
    if not _device_functions:
        from . import kernel_scatter, kernel_scatter_cuda

        _device_functions[kernel_scatter.scatter_add] = kernel_scatter_cuda.scatter_add
    form = _device_functions.get(function)
    if form is None:
        from numba.core.registry import CPUDispatcher

        body = function.py_func
        callees = {name: device_function(value) for name in body.__code__.co_names
                   if isinstance(value := body.__globals__.get(name), CPUDispatcher)}
        if callees:
            body = types.FunctionType(body.__code__, {**body.__globals__, **callees}, body.__name__,
                                      body.__defaults__, body.__closure__)
        form = _device_functions[function] = numba_cuda().jit(device=True)(body)
    return form


def cuda_problem() -> str | None:
    """Why the CUDA kernels cannot run in this process (``None`` where they can): torch sees no
    GPU, or numba-cuda is missing or finds no driver."""
    import torch

    if not torch.cuda.is_available():
        return "this torch is built without CUDA" if torch.version.cuda is None else "torch sees no CUDA GPU"
    try:
        cuda = numba_cuda()
    except DeviceError as e:
        return e.problem
    if not cuda.is_available():
        return "numba-cuda finds no CUDA driver"
    return None


def resolve_device(name: str):
    """``torch.device`` of the device setting ``name``: ``"cpu"``; ``"cuda"``, torch's current
    GPU (``DeviceError`` naming why where it cannot run, ``cuda_problem``); ``"auto"``, that GPU
    where it can run, else the CPU."""
    import torch

    if name == "cpu":
        return torch.device("cpu")
    problem = cuda_problem()
    if problem is None:
        return torch.device("cuda", torch.cuda.current_device())
    if name == "auto":
        return torch.device("cpu")
    raise DeviceError(problem)


def device_label(device) -> str:
    """What a report says of ``device``: ``"cpu"`` or e.g. ``"cuda:0 (NVIDIA H200)"``."""
    import torch

    device = torch.device(device)
    if device.type != "cuda":
        return device.type
    index = torch.cuda.current_device() if device.index is None else device.index
    return f"cuda:{index} ({torch.cuda.get_device_name(index)})"


def moved(value, device):
    """``value`` with every tensor in it on ``device``: a tensor, or a dataclass, list, tuple or
    dict holding tensors (nested), rebuilt around the moved tensors (a shallow copy of each
    dataclass, so ``init=False`` fields move too); anything else, and whatever holds no tensor
    off ``device``, is returned as it is (the same object). How a run carries its assets, views and
    references to the GPU in one call each."""
    if hasattr(value, "is_cuda"):
        return value.to(device)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
        changed = {name: v for name, old in fields.items() if (v := moved(old, device)) is not old}
        if not changed:
            return value
        twin = copy.copy(value)
        for name, v in changed.items():
            object.__setattr__(twin, name, v)
        return twin
    if isinstance(value, (list, tuple, dict)):
        items = list(value.items()) if isinstance(value, dict) else list(enumerate(value))
        twins = [(k, moved(v, device)) for k, v in items]
        if all(t is v for (_, v), (_, t) in zip(items, twins)):
            return value
        return dict(twins) if isinstance(value, dict) else type(value)(t for _, t in twins)
    return value


def device_failure(error: BaseException) -> str | None:
    """One line naming a failure of the GPU (torch's out of memory, a CUDA driver or runtime
    error from torch or numba-cuda), or ``None`` where ``error`` is not one."""
    torch = sys.modules.get("torch")
    if torch is not None and isinstance(error, torch.cuda.OutOfMemoryError):
        return f"the GPU is out of memory: {str(error).splitlines()[0]}"
    driver = sys.modules.get("numba.cuda.cudadrv.driver")
    if driver is not None and isinstance(error, getattr(driver, "CudaAPIError", ())):
        return f"the CUDA driver failed: {error}"
    if isinstance(error, RuntimeError) and "CUDA error" in str(error):
        return f"the GPU failed: {str(error).splitlines()[0]}"
    return None


def uses_cuda_kernels(tensor) -> bool:
    """Whether an op on ``tensor`` runs the CUDA form of its kernels: where the tensor is on the
    GPU (or, in the tests, ``cuda_kernels_for_cpu_tensors``)."""
    return tensor.is_cuda or _cuda_kernels_for_cpu_tensors


@contextlib.contextmanager
def cuda_kernels_for_cpu_tensors() -> Iterator[None]:
    """Within the block, the ops run the CUDA forms of their kernels on CPU tensors too: how the
    tests run them in Numba's CUDA simulator (a CPU tensor reaches the kernel as a NumPy array)."""
    global _cuda_kernels_for_cpu_tensors
    before, _cuda_kernels_for_cpu_tensors = _cuda_kernels_for_cpu_tensors, True
    try:
        yield
    finally:
        _cuda_kernels_for_cpu_tensors = before


def kernel_array(tensor):
    """``tensor`` as a CUDA kernel takes it, sharing its memory: a numba-cuda device array over a
    GPU tensor (``__cuda_array_interface__``, without synchronising: the kernels run on the
    tensor's stream), the NumPy array of a CPU tensor (the simulator's)."""
    tensor = tensor.detach()
    if tensor.is_cuda:
        return numba_cuda().as_cuda_array(tensor, sync=False)
    return tensor.numpy()


def launch(kernel, count: int, *args) -> None:
    """Run the CUDA ``kernel`` on ``count`` threads (``cuda.grid(1)`` is ``0 .. count - 1``; the
    kernel returns for the rest of the last block), on torch's current stream of its tensors'
    GPU. ``args``: tensors (passed by ``kernel_array``) and scalars."""
    global _launches
    if count <= 0:
        return
    _launches += 1
    cuda = numba_cuda()
    blocks = (count + THREADS_PER_BLOCK - 1) // THREADS_PER_BLOCK
    gpu = next((a.device for a in args if hasattr(a, "is_cuda") and a.is_cuda), None)
    arrays = [kernel_array(a) if hasattr(a, "is_cuda") else a for a in args]
    if gpu is None:  # CPU tensors: the simulator's launch
        kernel[blocks, THREADS_PER_BLOCK](*arrays)
        return
    import torch

    stream = cuda.external_stream(torch.cuda.current_stream(gpu).cuda_stream)
    kernel[blocks, THREADS_PER_BLOCK, stream](*arrays)


def launches() -> int:
    """CUDA kernels launched by this process so far (``bench render`` counts a frame's)."""
    return _launches
