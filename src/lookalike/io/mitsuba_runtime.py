"""Mitsuba 3 in this process: the ``mitsuba`` module with its variant chosen once.

Mitsuba runs its ``llvm_ad_rgb`` variant where an LLVM it works with is installed (``libLLVM``
16 or newer; found on the library path and proven in a separate process first, since an LLVM
it cannot use aborts the process), else ``scalar_rgb`` (about five times slower);
``path_tracer_variant`` says which. Nothing is imported or set before the first call.
"""

from __future__ import annotations

import functools
import glob
import os
import re
import sys

from ..errors import ConfigError, ExternalToolTimeout
from ..external_tools import run_tool

VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
"""Mitsuba variants in order of preference."""

MIN_LLVM = 16
"""Oldest LLVM major version tried for the ``llvm`` variant (older ones abort Dr.Jit)."""

LLVM_DIRS = ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib64", "/usr/lib", "/usr/local/lib")
"""Where ``libLLVM`` is looked for (besides ``DRJIT_LIBLLVM_PATH``)."""

PROBE = """
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
scene = mi.load_dict({"type": "scene", "integrator": {"type": "path"},
                      "s": {"type": "sphere", "bsdf": {"type": "principled", "roughness": 0.3}},
                      "l": {"type": "point", "position": [0, 0, 3]}})
sensor = mi.load_dict({"type": "perspective", "film": {"type": "hdrfilm", "width": 4, "height": 4}})
mi.render(scene, sensor=sensor, spp=1)
"""
"""A render in a child process: does Dr.Jit's LLVM back end work with this library?"""

PROBE_DEADLINE_S = 120.0
"""Longest the probe may take (it compiles one tiny render: seconds); one that hangs is killed
and the library passed over."""


def _llvm_libraries() -> list[str]:
    """``libLLVM`` files of major version ``MIN_LLVM`` or newer, newest first, the user's
    ``DRJIT_LIBLLVM_PATH`` before all."""
    found = {}
    for folder in LLVM_DIRS:
        for path in glob.glob(os.path.join(folder, "libLLVM*.so*")):
            match = re.search(r"libLLVM(?:-|\.so\.)(\d+)", os.path.basename(path))
            if match and int(match.group(1)) >= MIN_LLVM:
                found.setdefault(int(match.group(1)), path)
    user = os.environ.get("DRJIT_LIBLLVM_PATH")
    return ([user] if user else []) + [found[major] for major in sorted(found, reverse=True)]


@functools.cache
def path_tracer_variant() -> str:
    """The Mitsuba variant this process renders with (see the module); the first call probes
    LLVM in a child process (seconds) and points Dr.Jit at the library that worked."""
    for library in _llvm_libraries():
        env = {**os.environ, "DRJIT_LIBLLVM_PATH": library}
        try:
            probe = run_tool([sys.executable, "-c", PROBE], tool="Mitsuba's LLVM probe", subject=library,
                             deadline=PROBE_DEADLINE_S, env=env)
        except ExternalToolTimeout:
            continue
        if probe.returncode == 0:
            os.environ["DRJIT_LIBLLVM_PATH"] = library
            return VARIANTS[0]
    return VARIANTS[1]


def mitsuba():
    """The ``mitsuba`` module with ``path_tracer_variant`` set; ``ConfigError`` where it is not
    installed."""
    try:
        import mitsuba as mi
    except ImportError:
        raise ConfigError("the path-traced reference needs Mitsuba 3: pip install -e \".[pathtrace]\"") from None
    variant = path_tracer_variant()
    if mi.variant() != variant:
        mi.set_variant(variant)
    return mi
