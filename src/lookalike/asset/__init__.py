"""Assets: Mesh, Material, Skin, Asset; differentiable mesh operations live in the sibling modules
(normals, tangents, laplacian, subdivide, displace, skinning)."""

from .asset import Asset
from .material import ALPHA_MODES, Material, Texture
from .mesh import Mesh
from .skin import Animation, Channel, Node, Skin

__all__ = ["ALPHA_MODES", "Animation", "Asset", "Channel", "Material", "Mesh", "Node", "Skin", "Texture"]
