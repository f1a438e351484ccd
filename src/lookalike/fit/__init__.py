"""Appearance-driven optimisation of a low-poly latent model (paper Sec. 4 and 6).

Modules, each with one job: ``config`` (every setting), ``losses`` (image losses),
``schedule`` (learning rate and Laplacian weight), ``latent`` (the trainable model),
``initial`` (initial guess and the decimation baseline), ``views`` (random cameras and
lights), ``targets`` (reference images), ``optimize`` (the loop), ``evaluate`` (held-out
scores), ``outdir`` (atomic outputs), ``simplify`` (the whole job), ``demo_asset``.
"""

from .config import Config, load_config
from .simplify import SimplifyResult, simplify

__all__ = ["Config", "SimplifyResult", "load_config", "simplify"]
