"""Our views of a glb rendered by three.js in headless Chromium (``render.js``, ``page.html``).

three.js draws the file as its ``GLTFLoader`` reads it (metallic-roughness, normal, emissive
maps, ``KHR_materials_emissive_strength``, ``KHR_texture_basisu`` through its KTX2 loader,
``KHR_lights_punctual`` point lights in candela with inverse-square falloff), into a float render target with ``samples``-fold MSAA, without tone
mapping, so the pixels are linear radiance as ours are. It lights by the shading normal (no
horizon test), as real-time engines do. A batch of views runs with a deadline scaled to its
samples (``render_deadline``, ``lookalike.external_tools``).
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import torch

from ..errors import ConfigError, LookalikeError
from ..external_tools import run_tool
from ..shading.camera import Camera
from ..shading.light import PointLight

PACKAGE = Path(__file__).parent
"""This package's folder: ``render.js``, ``page.html`` and ``package.json``."""

MODULES_ENVIRONMENT, CHROMIUM_ENVIRONMENT = "LOOKALIKE_WEBGL_MODULES", "LOOKALIKE_CHROMIUM"
"""Where the npm packages (a ``node_modules`` folder) and the browser are, where not the defaults."""

DEFAULT_MODULES = Path.home() / ".cache" / "lookalike" / "webgl" / "node_modules"

BROWSERS = ("chromium", "chromium-browser", "google-chrome")

INSTALL_HINT = ("the three.js judge needs Node.js, Chromium and two npm packages: apt-get install nodejs npm chromium; "
                f"npm install --prefix {DEFAULT_MODULES.parent} three@0.170.0 puppeteer-core@23.11.1 "
                f"(or point {MODULES_ENVIRONMENT} at a node_modules folder holding them)")

BASE_S = 120.0
"""Seconds a batch of views may take besides drawing them: starting node and Chromium and
loading the model, on a busy machine."""

SECONDS_PER_SAMPLE = 3e-6
"""Seconds a batch may take per sample it draws (views x pixels x MSAA samples, at least one per
pixel): about ten times what headless Chromium takes on a busy 2-core machine without a GPU."""


def render_deadline(views: int, resolution: int, samples: int) -> float:
    """``BASE_S + SECONDS_PER_SAMPLE * views * resolution² * max(samples, 1)``: how long drawing
    ``views`` pictures of ``resolution``² pixels with ``samples``-fold MSAA may take."""
    return BASE_S + SECONDS_PER_SAMPLE * views * resolution ** 2 * max(samples, 1)


class WebglError(LookalikeError):
    """three.js or Chromium failed on a job (their message is in this one)."""


def _modules(modules: str | Path | None) -> Path:
    return Path(modules or os.environ.get(MODULES_ENVIRONMENT) or DEFAULT_MODULES)


def _browser() -> str | None:
    named = os.environ.get(CHROMIUM_ENVIRONMENT)
    return named if named else next((found for name in BROWSERS if (found := shutil.which(name))), None)


def threejs_available(modules: str | Path | None = None) -> bool:
    """Whether ``node``, a Chromium and the npm packages (in ``modules``, else
    ``$LOOKALIKE_WEBGL_MODULES``, else ``DEFAULT_MODULES``) are all there."""
    folder = _modules(modules)
    return (shutil.which("node") is not None and _browser() is not None
            and (folder / "three").is_dir() and (folder / "puppeteer-core").is_dir())


def require_threejs(modules: str | Path | None = None) -> None:
    """``ConfigError`` with the install line unless ``threejs_available``."""
    if not threejs_available(modules):
        raise ConfigError(INSTALL_HINT)


def render_threejs(model: str | Path, camera: Camera, resolution: int, light: PointLight | None = None,
                   samples: int = 4, modules: str | Path | None = None, shadows: bool = False) -> torch.Tensor:
    """``[B, H, W, 4]`` float32 pictures of the glb ``model`` by three.js from B cameras
    (``H = W = resolution``, row 0 at the top): linear RGB weighted by coverage, and coverage.
    ``light`` (batch 1, or one per camera): the point light of each view in place of the file's
    own lights (views scored as ours are); ``None`` keeps the file's. ``samples``: MSAA samples
    per pixel (0: one). ``shadows``: the given light casts shadows (three.js's shadow maps, as a
    viewer with shadows on draws them: alpha-tested cut-outs cast theirs).

    Raises ``ConfigError`` where three.js is not installed, ``WebglError`` where it fails,
    ``ExternalToolTimeout`` where it runs past ``render_deadline`` twice."""
    require_threejs(modules)
    views = []
    for k in range(camera.batch_size):
        view = {"mv": camera.mv[k].detach().double().reshape(-1).tolist(),
                "proj": camera.proj[k].detach().double().reshape(-1).tolist()}
        if light is not None:
            slot = 0 if light.position.shape[0] == 1 else k
            view["light"] = {"position": light.position[slot].tolist(), "intensity": light.intensity[slot].tolist()}
        views.append(view)
    with tempfile.TemporaryDirectory(prefix="lookalike-webgl-") as scratch:
        job, out = Path(scratch) / "job.json", Path(scratch) / "pictures.bin"
        job.write_text(json.dumps({"model": str(Path(model).resolve()), "views": views, "size": int(resolution),
                                   "samples": int(samples), "shadows": bool(shadows)}))
        done = run_tool(["node", str(PACKAGE / "render.js"), str(_modules(modules)), str(PACKAGE), _browser(),
                         str(job), str(out)], tool="three.js", subject=Path(model).name,
                        deadline=render_deadline(camera.batch_size, resolution, samples))
        if done.returncode != 0 or not out.is_file():
            raise WebglError(f"three.js failed on {model}: {done.stderr.strip()[-2000:]}")
        pixels = np.fromfile(out, dtype=np.float32).reshape(camera.batch_size, resolution, resolution, 4)
    return torch.from_numpy(np.ascontiguousarray(pixels[:, ::-1]))
