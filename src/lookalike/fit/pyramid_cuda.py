"""CUDA forms of the texture pyramid's upsampling (:mod:`.pyramid_kernels`): the same passes on
torch's CUDA tensors, one thread per row where the CPU forms run one ``prange`` iteration per
row, each running the CPU form's row body (compiled for the GPU by ``devices.device_function``);
the taps and their readers are the CPU form's, computed on the host (a few entries per row).
The plain-torch twin is :func:`.texture_pyramid.upsample`.
"""

from __future__ import annotations

import torch
from numba import cuda

from ..devices import device_function, launch
from . import pyramid_kernels as kernels

_widen_row = device_function(kernels.widen_row)
_add_row = device_function(kernels.add_row)
_adjoint_row = device_function(kernels.adjoint_row)


@cuda.jit
def _widen(coarse, c0, c1, fc, wide):
    """Thread per coarse row: :func:`.pyramid_kernels.widen_row`."""
    r = cuda.grid(1)
    if r < wide.shape[0]:
        _widen_row(coarse, c0, c1, fc, wide, r)


@cuda.jit
def _add(wide, r0, r1, fr, fine_rows, weight, inverse, lows, highs, out_rows):
    """Thread per fine row: :func:`.pyramid_kernels.add_row`."""
    y = cuda.grid(1)
    if y < out_rows.shape[0]:
        _add_row(wide, r0, r1, fr, fine_rows, weight, inverse, lows, highs, out_rows, y)


@cuda.jit
def _adjoint(fine_rows, row_start, row_output, row_weight, col_start, col_output, col_weight, rows, out):
    """Thread per coarse row: :func:`.pyramid_kernels.adjoint_row`, row ``y`` of ``rows``
    (zeroed) its scratch."""
    y = cuda.grid(1)
    if y < out.shape[0]:
        _adjoint_row(fine_rows, row_start, row_output, row_weight, col_start, col_output, col_weight, rows[y], out, y)


def _on(device, arrays):
    """The NumPy ``arrays`` as tensors on ``device``."""
    return [torch.from_numpy(a).to(device) for a in arrays]


def _scalar(value: float, dtype: torch.dtype):
    """``value`` as a NumPy scalar of ``dtype``, so that a kernel computes in that precision as the
    CPU form does (``out.dtype.type(value)``)."""
    return torch.empty(0, dtype=dtype).numpy().dtype.type(value)


def upsample_add(coarse: torch.Tensor, fine: torch.Tensor, scale: float, low: torch.Tensor, high: torch.Tensor,
                 out: torch.Tensor) -> None:
    """:func:`.pyramid_kernels.upsample_add` on the tensors' GPU: ``out [H, W, C] = clamp(scale
    fine + up(coarse [h, w, C]), low [C], high [C])``, the clamp's move divided by ``scale`` added
    to ``fine [H, W, C]`` (contiguous, changed in place)."""
    height, width, channels = out.shape
    rows = coarse.shape[0]
    r0, r1, fr = _on(out.device, kernels.axis_taps(rows, height))
    c0, c1, fc = _on(out.device, kernels.axis_taps(coarse.shape[1], width))
    wide = torch.empty(rows, width * channels, dtype=coarse.dtype, device=out.device)
    launch(_widen, rows, coarse, c0, c1, fc, wide)
    lows, highs = (b.to(device=out.device, dtype=out.dtype).repeat(width).contiguous() for b in (low, high))
    launch(_add, height, wide, r0, r1, fr, fine.view(height, -1), _scalar(scale, out.dtype),
           _scalar(1.0 / scale, out.dtype), lows, highs, out.view(height, -1))


def upsample_adjoint(grad: torch.Tensor, height: int, width: int) -> torch.Tensor:
    """:func:`.pyramid_kernels.upsample_adjoint` on the tensor's GPU: ``[height, width, C]``, the
    adjoint of upsampling to ``grad [H, W, C]``'s size (contiguous) applied to ``grad``."""
    fine_h, fine_w, channels = grad.shape
    row_readers = _on(grad.device, kernels.readers(height, fine_h))
    col_readers = _on(grad.device, kernels.readers(width, fine_w))
    out = torch.empty(height, width, channels, dtype=grad.dtype, device=grad.device)
    rows = torch.zeros(height, fine_w * channels, dtype=grad.dtype, device=grad.device)
    launch(_adjoint, height, grad.view(fine_h, -1), *row_readers, *col_readers, rows, out)
    return out
