"""Applications of the method: each module composes a reference, an initial guess, a latent
model, the optimisation loop and the outputs (``simplify``, ``bake``, ``demo``, ``convert``)."""
