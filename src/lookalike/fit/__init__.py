"""Appearance-driven optimisation of a latent model (paper Sec. 4 and 6), in parts that every
application composes:

- ``reference``: the ``Reference`` protocol (renders target images) and ``MeshReference``;
- ``training_views``: random views and the pool of reference images the steps draw from;
- ``latent``: the ``Latent`` protocol; ``textured_mesh``: ``TexturedMesh``, the mesh with PBR
  textures that ``simplify`` optimises;
- ``objective``: image loss + outline loss + scheduled regularisers (``losses``, ``schedule``);
- ``loop``: ``Fitter``, stepping, rollback, best-state keeping and the time budget;
  ``checkpoint``: writing and reading its state;
- ``config``: every setting, with its defaults; ``config_file``: TOML and option overrides.
"""
