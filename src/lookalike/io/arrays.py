"""Small array helpers shared by the format modules."""

from __future__ import annotations

import numpy as np

from ..asset import Texture


def unique_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct rows of ``rows [n, k]`` compared bitwise: the index ``[u]`` of each one's first
    occurrence and the inverse map ``[n]`` (row ``i`` equals row ``first[inverse[i]]``)."""
    rows = np.ascontiguousarray(rows)
    keys = rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    return first, inverse.reshape(-1)


def constant_texel(texture: Texture) -> np.ndarray | None:
    """The ``[C]`` float64 value of a texture whose texels are all equal, else ``None``."""
    data = texture.data.detach().cpu().numpy()
    first = data.reshape(-1, data.shape[-1])[0]
    return first.astype(np.float64) if np.all(data == first) else None
