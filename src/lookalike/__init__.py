"""lookalike: appearance-driven 3D model simplification on the CPU.

Implements Hasselgren et al. 2021, "Appearance-Driven Automatic 3D Model Simplification":
a low-poly mesh with PBR textures (the *latent* model) is rendered by a differentiable
rasterizer and optimised until its pictures match pictures of a reference asset.

Packages, each with one job (``render`` knows nothing of assets, ``asset`` nothing of
optimisation, ``fit`` composes them):

- ``lookalike.render``  differentiable rasterizer with nvdiffrast's contracts
- ``lookalike.colour``  sRGB encoding and the paper's tone map
- ``lookalike.asset``   Mesh, Material, Skin, Asset and differentiable mesh operations
- ``lookalike.io``      file formats (glTF, OBJ, PLY), registered by extension
- ``lookalike.shading`` BSDF, cameras, lights and the deferred rendering pipeline
- ``lookalike.init``    initial guesses (decimation, UV atlas, material atlas, bake)
- ``lookalike.fit``     targets, losses, schedules and the optimisation loop
- ``lookalike.report``  metrics, pictures and the HTML report
"""

from .version import __version__  # noqa: F401  (re-exported)


def __getattr__(name: str):
    """``lookalike.simplify`` is imported on first use, so that ``import lookalike`` stays light."""
    if name == "simplify":
        from .jobs.simplify import simplify
        return simplify
    raise AttributeError(f"module 'lookalike' has no attribute {name!r}")
