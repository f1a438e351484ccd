"""lookalike: appearance-driven 3D model simplification on the CPU.

Implements Hasselgren et al. 2021, "Appearance-Driven Automatic 3D Model Simplification":
a low-poly mesh with PBR textures (the *latent* model) is rendered by a differentiable
rasterizer and optimised until its pictures match pictures of a reference asset.

Packages in layers, each with one job (a package imports only from those listed after it;
``render`` knows nothing of assets, ``asset`` nothing of optimisation; ``init`` and ``fit``
never import each other, ``jobs`` composes them):

- ``lookalike.commands`` the ``lookalike`` command, one module per subcommand
- ``lookalike.bench``   benchmarks
- ``lookalike.jobs``    the run every application shares (``run``) and the applications:
  ``simplify``, ``cards``, ``lod``; ``bake``, ``demo``, ``batch``, the Blender judge
- ``lookalike.report``  the run's record, held-out scores, pictures and the HTML report
- ``lookalike.init``    initial guesses (decimation, UV atlas, material atlas, bake, billboard cloud)
- ``lookalike.fit``     references, latent models, the objective, the loop, checkpoints
- ``lookalike.blender`` Blender in a child process: Cycles renders, Blender's own bake
- ``lookalike.shading`` BSDF, cameras, lights and the deferred rendering pipeline
- ``lookalike.io``      file formats (glTF, OBJ, PLY), registered by extension; atomic writes
- ``lookalike.render``  differentiable rasterizer with nvdiffrast's contracts
- ``lookalike.asset``   Mesh, Material, Skin, Asset and differentiable mesh operations
- ``lookalike.settings`` every setting of a run, each default written once, and its TOML form
- ``lookalike.colour``  sRGB encoding and the paper's tone map

Importing lookalike changes nothing in the host process (its environment, its C heap), so that
it can live inside a notebook, Blender or a Ray worker; the ``lookalike`` command sets both for
its own process (``lookalike.kernel_cache``, ``lookalike.heap``).
"""

from .version import __version__  # noqa: F401  (re-exported)


def __getattr__(name: str):
    """``lookalike.simplify`` is imported on first use, so that ``import lookalike`` stays light."""
    if name == "simplify":
        from .jobs.simplify import simplify
        return simplify
    raise AttributeError(f"module 'lookalike' has no attribute {name!r}")
