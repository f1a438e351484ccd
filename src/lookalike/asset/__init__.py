"""Assets: Mesh, Material, Skin, Asset; mesh maths lives in the sibling modules: differentiable
operations (normals, tangents, edges, laplacian, subdivide, skinning) and NumPy texture-space
geometry (frames, uv_raster)."""

from .asset import Asset, PunctualLight
from .material import ALPHA_MODES, Material, Texture
from .mesh import Mesh
from .skin import Animation, Channel, Node, Skin

__all__ = ["ALPHA_MODES", "Animation", "Asset", "Channel", "Material", "Mesh", "Node", "PunctualLight", "Skin", "Texture"]
