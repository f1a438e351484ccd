"""Upper bounds of the settings that allocate memory or time in proportion to them, so that a
typo (``--texture-size 65536``) is a one-line error instead of minutes of swapping. Each bound
leaves a default run far inside the 24 GB of a development machine."""

MAX_TEXTURE_SIZE = 4096
"""Side of optimised textures: parameters, gradients, Adam's two moments and the best and
last-good copies make about 30 floats per texel (2 GB at 4096²)."""

MAX_BAKE_TEXTURE_SIZE = 8192
"""Side of baked or merged textures (no optimiser state: about 10 floats per texel)."""

MAX_RESOLUTION = 2048
"""Side of training, held-out and rendered images (the paper's largest)."""

MAX_SPP = 8
"""Samples per pixel per axis of supersampled or multisampled images."""

MAX_LAYERS = 16
"""Depth-peeled layers at most (each is a full-resolution pass)."""

MAX_VIEWS = 1024
"""Views in a pool, a held-out or validation set, or a batch of pictures."""

MAX_POOL_BYTES = 8 << 30
"""Memory of the pool of reference images (float16 RGBA: 8 bytes per pixel)."""

MAX_WORKERS = 1024
"""Tasks at once, and CPUs per task, of a batch."""

MAX_SKIN_CANDIDATES = 64
"""Candidate joints per vertex of a skinned fit: its blended skinning matrices take
``12 x candidates`` floats per vertex in every render."""

MAX_TESSELLATION_LEVEL = 5
"""Finest subdivision level a displacement map is fitted for (``4^5`` triangles per base triangle)."""

MAX_PATH_SPP = 4096
"""Samples per pixel of a path-traced reference view (each view costs time in proportion)."""

MAX_PATH_DEPTH = 64
"""Vertices of a path-traced path at most."""
