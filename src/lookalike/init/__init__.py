"""Initial guesses for the latent model: quadric decimation with attributes carried over
(``decimate``), a fresh UV atlas (``unwrap``), materials merged into one atlas (``atlas``), and
textures baked from the reference (``bake``)."""

from .decimate import decimate
from .unwrap import unwrap

__all__ = ["decimate", "unwrap"]
