"""Initial guesses for the latent model: quadric decimation with attributes carried over
(``decimate``), a fresh UV atlas (``unwrap``), and an icosphere (``icosphere``)."""

from .decimate import decimate
from .sphere import icosphere
from .unwrap import unwrap

__all__ = ["decimate", "icosphere", "unwrap"]
