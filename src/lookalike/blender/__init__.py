"""An independent judge: our views rendered by Blender Cycles, and Blender's own classic
pipeline (decimate, unwrap, bake) as a baseline.

Blender runs as the ``bpy`` package (the ``judge`` extra) in a child process
(``lookalike.blender.process``), never in the lookalike process. Modules:

- ``conversion``  our cameras and point lights in Blender's axes and units
- ``process``     ``judge_available``, and running a worker with a JSON job
- ``cycles``      ``render_cycles_views``: a glb under our views, ``[B, H, W, 4]`` with and
  without shadows (an animated glb posed per view by Blender's armature, at the view's clip and
  time)
- ``cycles_worker``  the Blender side of ``cycles``
- ``decimate_bake``  ``blender_classic_bake``: Blender's decimate + xatlas + selected-to-active
  bake (of still models), and ``blender_decimate_glb``: its Decimate alone, materials kept
- ``decimate_bake_worker``  the Blender side of ``decimate_bake``

This package imports nothing heavy on import, so that the workers (run with ``python -m``)
start quickly.
"""

from .process import INSTALL_HINT, JudgeError, judge_available, require_judge

__all__ = ["INSTALL_HINT", "JudgeError", "judge_available", "require_judge"]
