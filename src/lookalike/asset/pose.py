"""Poses of a skinned asset: which animation clip, at which time, each view shows.

A pose is a clip index into ``Asset.animations`` and a time in seconds; clip ``REST`` (-1) is
the rest pose, the skeleton's own node transforms with no animation applied (what a viewer
shows when nothing plays; for most files the bind pose).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import torch

REST = -1
"""The clip index of the rest pose."""


@dataclass
class Poses:
    """B poses.

    Attributes:
        clip: ``[B]`` int64 clip index into ``Asset.animations`` (``REST`` for the rest pose).
        time: ``[B]`` float32 seconds into the clip (0 for the rest pose).
    """

    clip: torch.Tensor
    time: torch.Tensor

    @staticmethod
    def of(clips, times) -> Poses:
        """Poses from sequences of clip indices and times."""
        return Poses(torch.as_tensor(clips, dtype=torch.int64).reshape(-1),
                     torch.as_tensor(times, dtype=torch.float32).reshape(-1))

    @staticmethod
    def rest(count: int) -> Poses:
        """``count`` rest poses."""
        return Poses(torch.full((count,), REST, dtype=torch.int64), torch.zeros(count))

    @staticmethod
    def cat(poses: list[Poses]) -> Poses:
        return Poses(torch.cat([p.clip for p in poses]), torch.cat([p.time for p in poses]))

    @property
    def batch_size(self) -> int:
        return int(self.clip.shape[0])

    def __getitem__(self, index) -> Poses:
        if isinstance(index, int):
            index = slice(index, index + 1)
        return Poses(self.clip[index], self.time[index])

    def runs(self) -> Iterator[tuple[slice, int, float]]:
        """``(views, clip, time)`` for each run of consecutive views that share one pose, in
        order: what a renderer draws with one posed geometry."""
        start = 0
        for k in range(1, self.batch_size + 1):
            if k == self.batch_size or self.clip[k] != self.clip[start] or self.time[k] != self.time[start]:
                yield slice(start, k), int(self.clip[start]), float(self.time[start])
                start = k
