"""Generated sample assets: the shrub of leaf meshes (``shrub``) and the other foliage kinds
(``foliage``), made in code so that tests, benchmarks and ``lookalike demo cards`` need no files."""
