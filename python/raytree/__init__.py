"""raytree: ray-tracing acceleration structures over numpy rays.

A `Scene` holds a triangle mesh (from numpy arrays, a file or a built-in
name); an `Accelerator` is one structure and traversal built over it, and
answers queries over numpy arrays of rays of any leading shape, in parallel
with the GIL released::

    import numpy as np, raytree
    scene = raytree.Scene.from_arrays(vertices, triangles)   # (N, 3) float, (M, 3) int
    accel = raytree.Accelerator(scene, "bvh")                 # or "dst", "bvh/laine-4", ...
    rays = np.concatenate([origins, directions], axis=-1)     # (..., 6) float32/float64
    ans = accel.cast_rays(rays)                               # t_hit, primitive_ids, ...

Queries: `Accelerator.cast_rays` (closest hit), `Accelerator.test_occlusions`
(any hit), `Accelerator.count_intersections` and
`Accelerator.list_intersections` (every hit), each with optional per-ray work
counters. Misses have ``t_hit = inf`` and ``primitive_ids = INVALID_ID``
(0xFFFFFFFF). `RayMeshIntersector` gives a trimesh mesh raytree's speed with
trimesh's ray API: ``mesh.ray = raytree.RayMeshIntersector(mesh)``.

Names: `STRUCTURES`, `TRAVERSALS` (for ``"bvh"``), `BUILDERS`.
"""

from ._raytree import (
    BUILDERS,
    INVALID_ID,
    STRUCTURES,
    TRAVERSALS,
    Accelerator,
    Scene,
    __version__,
)
from ._trimesh import RayMeshIntersector

__all__ = [
    "Accelerator",
    "BUILDERS",
    "INVALID_ID",
    "RayMeshIntersector",
    "STRUCTURES",
    "Scene",
    "TRAVERSALS",
    "__version__",
]
