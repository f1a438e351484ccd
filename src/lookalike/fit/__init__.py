"""Appearance-driven optimisation of a latent model (paper Sec. 4 and 6), in parts that every
application composes:

- ``reference``: the ``Reference`` protocol (renders target images) and ``MeshReference``;
- ``training_views``: random views and the pool of reference images the steps draw from;
- ``latent``: the ``Latent`` protocol; ``textured_mesh``: ``TexturedMesh``, the mesh with PBR
  textures that ``simplify`` optimises;
- ``objective``: image loss + outline loss + scheduled regularisers (``losses``, ``schedule``);
- ``loop``: ``Fitter``, stepping and rollback; ``best_state``, ``pacing``, ``progress_bar``: the
  loop's best state, time budget and bar; ``checkpoint``: writing and reading its state;
- ``from_settings``: the loop's settings and the objective as a run's settings describe them.
"""
