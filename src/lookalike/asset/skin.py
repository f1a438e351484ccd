"""Skeletons and animations, as glTF stores them.

Joint world matrices at time t come from the node hierarchy with animated TRS; the skinning
matrix of joint j is ``world(joint_j) @ inverse_bind[j]`` (glTF 2.0, Sec. 3.7.3), applied to
bind-pose vertex positions that are already in the asset's frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import torch


@dataclass
class Node:
    """A scene node: local TRS (translation ``[3]``, rotation quaternion ``[4]`` xyzw,
    scale ``[3]``), parent index (-1 for a root) and name."""

    name: str
    parent: int
    translation: torch.Tensor
    rotation: torch.Tensor
    scale: torch.Tensor


@dataclass
class Channel:
    """One animated property of one node.

    Attributes:
        node: index into ``Skin.nodes``.
        path: ``"translation"``, ``"rotation"`` or ``"scale"``.
        times: ``[K]`` float32 key times in seconds, increasing.
        values: the sampler's output as glTF stores it: ``[K, 3]`` or ``[K, 4]`` (quaternion
            xyzw) key values for ``LINEAR`` and ``STEP``; ``[3K, C]`` for ``CUBICSPLINE``, each
            key's in-tangent, value and out-tangent in turn.
        interpolation: ``"LINEAR"`` (slerp for rotations), ``"STEP"`` or ``"CUBICSPLINE"``
            (cubic Hermite, glTF 2.0 Appendix C).
    """

    node: int
    path: str
    times: torch.Tensor
    values: torch.Tensor
    interpolation: str = "LINEAR"


@dataclass
class Animation:
    """A named clip: a list of channels; ``duration`` is the last key time."""

    name: str
    channels: list[Channel] = field(default_factory=list)

    @property
    def duration(self) -> float:
        return max((float(c.times[-1]) for c in self.channels), default=0.0)


@dataclass
class Skin:
    """A skeleton.

    Attributes:
        nodes: every node of the scene graph that a joint or its ancestors use.
        joints: ``[J]`` int64 indices into ``nodes``; vertex joint index ``k`` means
            ``nodes[joints[k]]``.
        inverse_bind: ``[J, 4, 4]`` float32 inverse bind matrices, for bind-pose positions in
            the frame ``inverse(mesh_to_world)`` maps the mesh's positions to.
        mesh_to_world: ``[4, 4]`` transform that was applied to the bind-pose mesh on load
            (the skinned mesh node's world matrix), so that skinning can undo it:
            glTF ignores the mesh node's transform for skinned meshes.
        name: the skin's name in the file (``""``: none).
        skeleton: index into ``nodes`` of the skeleton's root (glTF ``skin.skeleton``), or ``None``.
        mesh_node: index into ``nodes`` of the node that held the (first) skinned mesh, where
            the skin was read from a file: a writer puts the mesh back there, so that the node
            tree keeps its shape; ``None``: a node of its own.
    """

    nodes: list[Node]
    joints: torch.Tensor
    inverse_bind: torch.Tensor
    mesh_to_world: torch.Tensor = field(default_factory=lambda: torch.eye(4))
    name: str = ""
    skeleton: int | None = None
    mesh_node: int | None = None
