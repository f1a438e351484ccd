"""Applications of the method on the run they share (``run``: settings, input, initial guess,
views, baselines, the loop, outputs): ``simplify``, ``cards``, ``lod``; and the jobs around them:
``bake`` (the classic pipeline), ``demo``, ``batch`` (many assets on Ray), ``judge`` (scores
in Blender Cycles)."""
