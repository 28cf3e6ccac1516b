"""trimesh's ray-intersector API over raytree.

trimesh meshes answer ray queries through ``mesh.ray``, an object with
``intersects_first``, ``intersects_any``, ``intersects_id``,
``intersects_location`` and ``contains_points``. `RayMeshIntersector` has
the same methods, signatures and return values, so that existing code
changes one line::

    mesh.ray = raytree.RayMeshIntersector(mesh)

trimesh itself is not imported here (but for ``contains_points``, which
runs trimesh's own parity test over these methods): any object with
``vertices`` (N, 3) and ``faces`` (M, 3) arrays will do.
"""

from __future__ import annotations

from typing import Any, Literal, Optional

import numpy as np

from ._raytree import INVALID_ID, Accelerator, Scene


class RayMeshIntersector:
    """Ray queries on a trimesh mesh (or any object with ``vertices`` and
    ``faces``), with the methods of trimesh's ``RayMeshIntersector``.

    Rays start at their origin (t >= 0) and run to infinity; directions need
    not be unit length. Triangles are indices into ``mesh.faces``. The mesh
    is traced in float32. The structure is built at the first query and
    rebuilt when ``hash(mesh)`` changes (trimesh hashes a mesh's content;
    another object keeps the structure it was first built with).

    Args:
        mesh: a ``trimesh.Trimesh``, or any object with ``vertices`` (N, 3)
            float and ``faces`` (M, 3) int.
        structure, traversal, builder, sah_block: as `raytree.Accelerator`
            (``structure="bvh8"`` is the fastest on one core; its default
            ``sah_block`` is 4).
        threads: worker threads for builds and queries (None: all cores).
        invalid_rays: ``"miss"`` (the default, as trimesh: a NaN or zero
            direction hits nothing) or ``"raise"``.
    """

    def __init__(
        self,
        mesh: Any,
        structure: str = "bvh",
        traversal: Optional[str] = None,
        builder: str = "sah",
        threads: Optional[int] = None,
        invalid_rays: Literal["raise", "miss"] = "miss",
        sah_block: Optional[int] = None,
    ) -> None:
        for attribute in ("vertices", "faces"):
            if not hasattr(mesh, attribute):
                raise TypeError(
                    f"mesh must have 'vertices' and 'faces' arrays (a trimesh.Trimesh); "
                    f"{type(mesh).__name__} has no '{attribute}'"
                )
        self.mesh = mesh
        self._structure, self._traversal, self._builder = structure, traversal, builder
        self._threads = threads
        self._sah_block = sah_block
        self._invalid: Literal["raise", "miss"] = invalid_rays
        self._accel: Optional[Accelerator] = None
        self._key: Any = None

    def _mesh_key(self) -> Any:
        try:
            return hash(self.mesh)
        except TypeError:
            return id(self.mesh)

    @property
    def accelerator(self) -> Accelerator:
        """The `raytree.Accelerator` over the mesh (built on first use, and
        again when the mesh's hash changes)."""
        key = self._mesh_key()
        if self._accel is None or key != self._key:
            scene = Scene.from_arrays(
                np.asarray(self.mesh.vertices), np.asarray(self.mesh.faces), name="trimesh"
            )
            self._accel = Accelerator(
                scene,
                self._structure,
                traversal=self._traversal,
                builder=self._builder,
                threads=self._threads,
                sah_block=self._sah_block,
            )
            self._key = key
        return self._accel

    def _rays(self, ray_origins: Any, ray_directions: Any) -> np.ndarray:
        o = np.asarray(ray_origins, dtype=np.float64)
        d = np.asarray(ray_directions, dtype=np.float64)
        if o.shape != d.shape:
            raise ValueError(
                f"ray_origins {o.shape} and ray_directions {d.shape} must have the same shape (n, 3)"
            )
        if o.ndim != 2 or o.shape[1] != 3:
            raise ValueError(f"ray_origins and ray_directions must have shape (n, 3), got {o.shape}")
        return np.concatenate([o, d], axis=1)

    def intersects_first(self, ray_origins: Any, ray_directions: Any, **kwargs: Any) -> np.ndarray:
        """The nearest triangle each ray hits.

        Args:
            ray_origins: (n, 3) float.
            ray_directions: (n, 3) float, any length.

        Returns:
            (n,) int64: index into ``mesh.faces``, or -1 where the ray hits
            nothing.
        """
        _no_kwargs("intersects_first", kwargs)
        rays = self._rays(ray_origins, ray_directions)
        ids = self.accelerator.cast_rays(rays, threads=self._threads, invalid_rays=self._invalid)[
            "primitive_ids"
        ].astype(np.int64)
        ids[ids == INVALID_ID] = -1
        return ids

    def intersects_any(self, ray_origins: Any, ray_directions: Any, **kwargs: Any) -> np.ndarray:
        """Whether each ray hits the mesh (an any-hit query).

        Returns:
            (n,) bool.
        """
        _no_kwargs("intersects_any", kwargs)
        rays = self._rays(ray_origins, ray_directions)
        return self.accelerator.test_occlusions(
            rays, threads=self._threads, invalid_rays=self._invalid
        )

    def intersects_id(
        self,
        ray_origins: Any,
        ray_directions: Any,
        multiple_hits: bool = True,
        max_hits: Optional[int] = None,
        return_locations: bool = False,
        **kwargs: Any,
    ):
        """The triangles hit by the rays.

        Args:
            ray_origins: (n, 3) float.
            ray_directions: (n, 3) float.
            multiple_hits: every hit along each ray (True) or the nearest
                only (False).
            max_hits: with multiple_hits, keep at most this many (the
                nearest) per ray; None keeps all.
            return_locations: also return the hit points. As trimesh's
                default intersector, hits of one ray at the same point (a
                ray through an edge shared by two triangles) are then
                reported once, for the smaller triangle index.

        Returns:
            index_tri (h,) int64, index_ray (h,) int64 and, with
            return_locations, locations (h, 3) float64: origin + t·direction.
            Hits come ray by ray, nearest first.
        """
        _no_kwargs("intersects_id", kwargs)
        rays = self._rays(ray_origins, ray_directions)
        accel = self.accelerator
        if not multiple_hits:
            ans = accel.cast_rays(rays, threads=self._threads, invalid_rays=self._invalid)
            index_ray = np.flatnonzero(ans["primitive_ids"] != INVALID_ID)
            index_tri = ans["primitive_ids"][index_ray].astype(np.int64)
            t = ans["t_hit"][index_ray].astype(np.float64)
        else:
            ans = accel.list_intersections(
                rays, threads=self._threads, invalid_rays=self._invalid, max_hits=max_hits
            )
            index_ray = ans["ray_ids"]
            index_tri = ans["primitive_ids"].astype(np.int64)
            t = ans["t_hit"].astype(np.float64)
            if return_locations and len(t) > 1:
                # Sorted by ray, then distance, then triangle: a repeat of
                # the previous (ray, t) is the same point.
                keep = np.ones(len(t), dtype=bool)
                keep[1:] = (index_ray[1:] != index_ray[:-1]) | (t[1:] != t[:-1])
                index_ray, index_tri, t = index_ray[keep], index_tri[keep], t[keep]
        if return_locations:
            locations = rays[index_ray, :3] + t[:, None] * rays[index_ray, 3:]
            return index_tri, index_ray, locations
        return index_tri, index_ray

    def intersects_location(
        self, ray_origins: Any, ray_directions: Any, multiple_hits: bool = True, **kwargs: Any
    ):
        """Where the rays hit the mesh.

        Returns:
            locations (h, 3) float64, index_ray (h,) int64, index_tri (h,)
            int64; as `intersects_id` with ``return_locations=True``.
        """
        index_tri, index_ray, locations = self.intersects_id(
            ray_origins,
            ray_directions,
            multiple_hits=multiple_hits,
            return_locations=True,
            **kwargs,
        )
        return locations, index_ray, index_tri

    def contains_points(self, points: Any) -> np.ndarray:
        """Whether each point is inside the mesh, by trimesh's own ray parity
        test (needs trimesh). Points on the surface are undefined.

        Returns:
            (n,) bool.
        """
        from trimesh.ray.ray_util import contains_points

        return contains_points(self, np.asarray(points, dtype=np.float64))

    def __repr__(self) -> str:
        name = self._structure + (f"/{self._traversal}" if self._traversal else "")
        return f"RayMeshIntersector({type(self.mesh).__name__}, {name!r}, builder={self._builder!r})"


def _no_kwargs(method: str, kwargs: dict) -> None:
    if kwargs:
        raise TypeError(f"{method}() got unexpected keyword arguments: {sorted(kwargs)}")
