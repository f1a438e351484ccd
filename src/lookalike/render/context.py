"""The rasterizer context, kept for nvdiffrast compatibility."""

from __future__ import annotations


class RasterizeContext:
    """Stand-in for nvdiffrast's ``RasterizeGLContext`` / ``RasterizeCudaContext``.

    The CPU rasterizer keeps no state between calls, so the context only exists so that
    nvdiffrast code runs unchanged; :func:`lookalike.render.rasterize` accepts ``None`` too.
    Constructor arguments nvdiffrast accepts (``output_db``, ``device``, ...) are ignored.
    """

    def __init__(self, *args, **kwargs):
        pass

    def __repr__(self) -> str:
        return "RasterizeContext(cpu)"


RasterizeCudaContext = RasterizeContext
"""nvdiffrast's CUDA context name, so ``dr.RasterizeCudaContext()`` keeps working."""

RasterizeGLContext = RasterizeContext
"""nvdiffrast's OpenGL context name, so ``dr.RasterizeGLContext()`` keeps working."""
