"""Type stubs of the extension module raytree._raytree (Rust, PyO3).

Shapes: ``...`` is the rays' leading shape (any, including ``()``); R is the
number of rays (the leading shape's product) and K the number of hits.
Distances ``t`` are in units of each ray's direction (not normalized).
"""

import os
from typing import Literal, Optional, Sequence, Union, final, overload

import numpy as np
import numpy.typing as npt

#: primitive_ids / geometry_ids of a miss: 0xFFFFFFFF (as Open3D's).
INVALID_ID: int
#: Structure names: bvh, dst, dst-similar, bih, htree, cbvh, bvh4, bvh8, brute.
STRUCTURES: tuple[str, ...]
#: Traversal names (for "bvh"): stack, implicit-a, implicit-b, sparse, hapala, laine-0/1/2/4/8.
TRAVERSALS: tuple[str, ...]
#: Builder names: sah, hybrid, sbvh, lbvh.
BUILDERS: tuple[str, ...]
__version__: str
__all__ = ["Accelerator", "BUILDERS", "INVALID_ID", "STRUCTURES", "Scene", "TRAVERSALS", "__version__"]

#: A ray interval end: a number, or an array broadcasting to the leading
#: shape; None for the default (tmin 0, tmax inf).
_End = Union[float, npt.ArrayLike, None]
_InvalidRays = Literal["raise", "miss"]

@final
class Scene:
    """A triangle mesh, kept in float32. Triangle i is row i of `triangles`."""

    @staticmethod
    def from_arrays(
        vertices: npt.ArrayLike, triangles: npt.ArrayLike, name: Optional[str] = None
    ) -> Scene:
        """vertices (N, 3) float32/float64; triangles (M, 3) any integer dtype, in 0..N."""
    @staticmethod
    def load(
        path: Union[str, os.PathLike[str], Sequence[Union[str, os.PathLike[str]]]],
        gltf_scene: Optional[int] = None,
    ) -> Scene:
        """Mesh files (OBJ, PLY, STL, glTF, GLB): one, or a list made one scene."""
    @staticmethod
    def builtin(spec: str) -> Scene:
        """A procedural scene: "chess", "chess:20000", "hairball:1M", "atrium", "forest", "plant"."""
    @property
    def name(self) -> str: ...
    @property
    def triangle_count(self) -> int: ...
    @property
    def vertex_count(self) -> int: ...
    @property
    def vertices(self) -> npt.NDArray[np.float32]:
        """(N, 3) float32, a copy."""
    @property
    def triangles(self) -> npt.NDArray[np.uint32]:
        """(M, 3) uint32, a copy."""
    @property
    def bounds(self) -> npt.NDArray[np.float32]:
        """(2, 3) float32: min row, max row."""
    @property
    def geometries(self) -> list[dict]:
        """One dict per geometry: name, first_triangle, triangle_count."""
    def geometry_of(
        self, primitive_ids: npt.ArrayLike
    ) -> tuple[npt.NDArray[np.uint32], npt.NDArray[np.uint32]]:
        """(geometry_ids, local_ids), uint32 of the input's shape; INVALID_ID for misses."""
    def __len__(self) -> int: ...

@final
class Accelerator:
    """One structure and traversal built over a Scene, answering ray queries."""

    def __new__(
        cls,
        scene: Scene,
        structure: str = "bvh",
        traversal: Optional[str] = None,
        builder: str = "sah",
        max_leaf_size: int = 8,
        threads: Optional[int] = None,
        sah_block: Optional[int] = None,
    ) -> Accelerator: ...
    @property
    def structure(self) -> str: ...
    @property
    def traversal(self) -> Optional[str]: ...
    @property
    def builder(self) -> str: ...
    @property
    def bytes(self) -> int: ...
    @property
    def scene(self) -> Scene: ...
    def info(self) -> dict:
        """Storage (bytes) and node statistics of the structure, and the BVH's build report under "bvh"."""
    def cast_rays(
        self,
        rays: npt.ArrayLike,
        tmin: _End = None,
        tmax: _End = None,
        threads: Optional[int] = None,
        counters: bool = False,
        invalid_rays: _InvalidRays = "raise",
    ) -> dict[str, np.ndarray]:
        """Closest hits of (..., 6) rays: t_hit (...) float32 (inf on a miss),
        primitive_ids (...) uint32 (INVALID_ID on a miss), geometry_ids (...)
        uint32, primitive_uvs (..., 2) float32, primitive_normals (..., 3)
        float32; with counters also nodes, plane_tests, triangle_tests (...) uint32."""
    @overload
    def test_occlusions(
        self,
        rays: npt.ArrayLike,
        tmin: _End = None,
        tmax: _End = None,
        threads: Optional[int] = None,
        counters: Literal[False] = False,
        invalid_rays: _InvalidRays = "raise",
    ) -> npt.NDArray[np.bool_]: ...
    @overload
    def test_occlusions(
        self,
        rays: npt.ArrayLike,
        tmin: _End = None,
        tmax: _End = None,
        threads: Optional[int] = None,
        *,
        counters: Literal[True],
        invalid_rays: _InvalidRays = "raise",
    ) -> dict[str, np.ndarray]: ...
    @overload
    def count_intersections(
        self,
        rays: npt.ArrayLike,
        tmin: _End = None,
        tmax: _End = None,
        threads: Optional[int] = None,
        counters: Literal[False] = False,
        invalid_rays: _InvalidRays = "raise",
    ) -> npt.NDArray[np.uint32]: ...
    @overload
    def count_intersections(
        self,
        rays: npt.ArrayLike,
        tmin: _End = None,
        tmax: _End = None,
        threads: Optional[int] = None,
        *,
        counters: Literal[True],
        invalid_rays: _InvalidRays = "raise",
    ) -> dict[str, np.ndarray]: ...
    def list_intersections(
        self,
        rays: npt.ArrayLike,
        tmin: _End = None,
        tmax: _End = None,
        threads: Optional[int] = None,
        counters: bool = False,
        invalid_rays: _InvalidRays = "raise",
        max_hits: Optional[int] = None,
    ) -> dict[str, np.ndarray]:
        """Every hit, nearest first: ray_splits (R+1,) int64, ray_ids (K,)
        int64, t_hit (K,) float32, primitive_ids (K,) uint32, geometry_ids
        (K,) uint32, primitive_uvs (K, 2), primitive_normals (K, 3) float32;
        with counters also nodes, plane_tests, triangle_tests (...) uint32."""
    def _rust_batch(
        self,
        rays: npt.ArrayLike,
        tmin: _End = None,
        tmax: _End = None,
        threads: Optional[int] = None,
    ) -> tuple[float, float, float, float, int]:
        """Benchmarks: wall and CPU seconds of the core's own batch call on these rays (rays built
        from the arrays, then traced), wall and CPU seconds of the trace alone, and hits."""
