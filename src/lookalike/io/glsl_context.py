"""One headless OpenGL context for the process (moderngl on EGL: Mesa's software rasterizer
llvmpipe where there is no GPU), created when first asked for, and shader compilation whose
errors name the user's file and line."""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import AssetError, UserCodeError

_CONTEXT = []

USER_LINE = "#line 1\n"
"""Put before the user's source in a generated shader, so the compiler numbers its lines as the
user's file does."""

OURS_FIRST_LINE = 100_000
"""Our code after the user's starts at this line number (``#line``): an error there is ours."""

_MESSAGE = re.compile(r"^\s*\d+:(\d+)\(\d+\):\s*(?:error|ERROR):\s*(.*)$", re.MULTILINE)


def gl_context(path: Path):
    """The process's ``moderngl`` standalone context (EGL); ``AssetError`` naming ``path`` and the
    Debian packages it needs where no OpenGL 3.3 context can be made."""
    if not _CONTEXT:
        try:
            import moderngl
            _CONTEXT.append(moderngl.create_standalone_context(backend="egl", require=330))
        except Exception as e:  # any failure to find a driver
            raise AssetError(path, f"cannot create a headless OpenGL 3.3 context ({e}); install Debian's "
                             "libegl1, libegl-mesa0 and libgl1-mesa-dri") from None
    return _CONTEXT[0]


def ours_after_user() -> str:
    """The ``#line`` directive that follows the user's source in a generated shader."""
    return f"\n#line {OURS_FIRST_LINE}\n"


def compile_program(path: Path, vertex: str, fragment: str):
    """A ``moderngl`` program of ``vertex`` and ``fragment`` (which holds the user's file ``path``
    after ``USER_LINE``); a compile or link error in their lines is a ``UserCodeError`` at their
    line with the compiler's message."""
    context = gl_context(path)
    import moderngl
    try:
        return context.program(vertex_shader=vertex, fragment_shader=fragment)
    except moderngl.Error as e:
        log = str(e)
        for line, message in _MESSAGE.findall(log):
            if int(line) < OURS_FIRST_LINE:
                raise UserCodeError(path, int(line), f"GLSL: {message.strip()}") from None
        first = log.strip().splitlines()[-1] if log.strip() else "the shader did not compile"
        raise UserCodeError(path, None, f"GLSL: {first.strip()}") from None
