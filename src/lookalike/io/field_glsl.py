"""Signed distance fields written in GLSL, ShaderToy style: a ``.glsl`` file defining
``float map(vec3 p)`` (negative inside), optionally ``vec3 albedo(vec3 p)`` (linear base colour),
``float roughness(vec3 p)`` and ``float metallic(vec3 p)``, and a line
``// bounds: xmin ymin zmin xmax ymax zmax``; read as an ``ImplicitSurface`` whose functions run
in a real OpenGL context (``io.glsl_context``), one fragment per point.

The shader is the user's own code: a compile error is reported at their line with the
compiler's message (``UserCodeError``).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import torch

from ..asset import Asset
from ..asset.implicit import ImplicitSurface
from ..errors import AssetError
from .field_asset import checked_distances, field_asset, parse_bounds
from .glsl_context import USER_LINE, compile_program, gl_context, ours_after_user
from .registry import reader

FULL_SCREEN = """#version 330
const vec2 lk_corners[3] = vec2[3](vec2(-1.0, -1.0), vec2(3.0, -1.0), vec2(-1.0, 3.0));
void main() { gl_Position = vec4(lk_corners[gl_VertexID], 0.0, 1.0); }
"""
"""The vertex shader of every generated program: one triangle over the whole target."""

OPTIONAL_FUNCTIONS = {"albedo": r"\bvec3\s+albedo\s*\(\s*vec3", "roughness": r"\bfloat\s+roughness\s*\(\s*vec3",
                      "metallic": r"\bfloat\s+metallic\s*\(\s*vec3"}
"""The material functions a field may define, and how to find each in its source."""

MATERIAL_DEFAULTS = """
vec3 lk_albedo(vec3 p) {
#ifdef LK_HAS_ALBEDO
    return albedo(p);
#else
    return vec3(0.75, 0.72, 0.68);
#endif
}
float lk_roughness(vec3 p) {
#ifdef LK_HAS_ROUGHNESS
    return roughness(p);
#else
    return 0.45;
#endif
}
float lk_metallic(vec3 p) {
#ifdef LK_HAS_METALLIC
    return metallic(p);
#else
    return 0.0;
#endif
}
"""
"""What a field that defines no material function gets: an untextured mesh's material
(``lookalike.asset.implicit.DEFAULT_BASE_COLOR``, ``DEFAULT_ROUGHNESS``)."""

POINTS_UNIFORMS = """uniform sampler2D lk_points;
uniform int lk_channel;
out vec4 lk_result;
"""

POINTS_MAIN = """
void main() {
    vec3 p = texelFetch(lk_points, ivec2(gl_FragCoord.xy), 0).xyz;
    if (lk_channel == 0) lk_result = vec4(map(p), 0.0, 0.0, 0.0);
    else if (lk_channel == 1) lk_result = vec4(lk_albedo(p), lk_roughness(p));
    else lk_result = vec4(lk_metallic(p), 0.0, 0.0, 0.0);
}
"""
"""Point ``gl_FragCoord`` of the target reads its point from ``lk_points`` and writes channel
``lk_channel``: 0 the distance, 1 base colour and roughness, 2 metalness."""

POINTS_WIDTH, POINTS_ROWS = 4096, 512
"""Points evaluated per draw: a target of this many columns and at most this many rows."""


def field_header(source: str) -> str:
    """``#version 330`` and a ``#define LK_HAS_NAME`` for each optional function ``source``
    defines."""
    defines = [f"#define LK_HAS_{name.upper()}\n" for name, pattern in OPTIONAL_FUNCTIONS.items()
               if re.search(pattern, source)]
    return "#version 330\n" + "".join(defines)


class GlslPoints:
    """The user's GLSL functions at points: ``map`` (``[N, 3] -> [N]``) or the material
    (``[N, 3] -> dict``), one fragment per point, ``POINTS_WIDTH * POINTS_ROWS`` at a time."""

    def __init__(self, path: Path, source: str):
        self.path = path
        fragment = (field_header(source) + POINTS_UNIFORMS + USER_LINE + source + ours_after_user()
                    + MATERIAL_DEFAULTS + POINTS_MAIN)
        self.program = compile_program(path, FULL_SCREEN, fragment)

    def evaluate(self, points: torch.Tensor, channel: int) -> np.ndarray:
        """``[N, 4]`` float32 ``lk_result`` of ``points [N, 3]`` for ``channel`` (``POINTS_MAIN``)."""
        context = gl_context(self.path)
        n = points.shape[0]
        out = np.empty((n, 4), np.float32)
        per_draw = POINTS_WIDTH * POINTS_ROWS
        vao = context.vertex_array(self.program, [])
        for start in range(0, n, per_draw):
            chunk = points[start:start + per_draw].detach().float().numpy()
            count = chunk.shape[0]
            width = min(count, POINTS_WIDTH)
            rows = -(-count // width)
            padded = np.zeros((rows * width, 3), np.float32)
            padded[:count] = chunk
            source = context.texture((width, rows), 3, padded.tobytes(), dtype="f4")
            target = context.texture((width, rows), 4, dtype="f4")
            frame = context.framebuffer(color_attachments=[target])
            frame.use()
            source.use(location=0)
            self.program["lk_points"] = 0
            self.program["lk_channel"] = channel
            vao.render(vertices=3)
            out[start:start + count] = np.frombuffer(frame.read(components=4, dtype="f4"), np.float32).reshape(-1, 4)[:count]
            for resource in (frame, target, source):
                resource.release()
        vao.release()
        return out


class GlslField:
    """``map`` of a GLSL field as a ``Field``."""

    def __init__(self, points: GlslPoints):
        self.points = points

    def __call__(self, p: torch.Tensor) -> torch.Tensor:
        return checked_distances(torch.from_numpy(self.points.evaluate(p, 0)[:, 0].copy()), p, self.points.path)


class GlslMaterial:
    """``albedo``, ``roughness`` and ``metallic`` of a GLSL field as a ``MaterialField``."""

    def __init__(self, points: GlslPoints):
        self.points = points

    def __call__(self, p: torch.Tensor) -> dict:
        colour = torch.from_numpy(self.points.evaluate(p, 1).copy())
        metal = torch.from_numpy(self.points.evaluate(p, 2)[:, 0].copy())
        return {"base_color": colour[:, :3], "roughness": colour[:, 3], "metallic": metal}


BOUNDS_LINE = re.compile(r"^\s*//\s*bounds\s*:(.*)$", re.MULTILINE | re.IGNORECASE)


VERSION_LINE = re.compile(r"^[ \t]*#[ \t]*version\b.*$", re.MULTILINE)


def load_glsl_field(path: Path) -> ImplicitSurface:
    """The ``ImplicitSurface`` that the GLSL file ``path`` defines (a ``#version`` line of its
    own is blanked: the generated shader states its version first)."""
    source = VERSION_LINE.sub("", path.read_text(encoding="utf-8", errors="replace"))
    if not re.search(r"\bfloat\s+map\s*\(\s*vec3", source):
        raise AssetError(path, "defines no function float map(vec3 p) (the signed distance, negative inside)")
    found = BOUNDS_LINE.search(source)
    if found is None:
        raise AssetError(path, "has no line '// bounds: xmin ymin zmin xmax ymax zmax'")
    numbers = found.group(1).split()
    if len(numbers) != 6:
        raise AssetError(path, f"its bounds line must give six numbers, not {found.group(1).strip()!r}")
    lo, hi = parse_bounds((numbers[:3], numbers[3:]), path)
    points = GlslPoints(path, source)
    has_material = any(re.search(pattern, source) for pattern in OPTIONAL_FUNCTIONS.values())
    return ImplicitSurface(sdf=GlslField(points), material=GlslMaterial(points) if has_material else None,
                           lo=lo, hi=hi, text=source, kind="glsl", path=path)


@reader(".glsl")
def read_glsl_field(path: Path) -> Asset:
    return field_asset(load_glsl_field(path), path)
