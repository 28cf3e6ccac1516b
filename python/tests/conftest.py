"""Shared fixtures: small scenes, rays aimed at them, and every structure and
traversal name (the oracle is the ``brute`` structure: every triangle)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import raytree

#: Every structure and traversal raytree builds, by name.
CONFIGURATIONS = [f"bvh/{t}" for t in raytree.TRAVERSALS] + [
    s for s in raytree.STRUCTURES if s not in ("bvh", "brute")
]

#: The meshes shared with the Rust tests (../shared/scenes beside the
#: repository), when present.
SHARED = Path(__file__).resolve().parents[3] / "shared" / "scenes"


def make_rays(scene: raytree.Scene, n: int, seed: int = 7) -> np.ndarray:
    """(n, 6) float32 rays: most from around the scene towards a triangle's
    centroid, some in random directions, some along the axes (zero
    direction components), some starting inside."""
    rng = np.random.default_rng(seed)
    v = scene.vertices.astype(np.float64)
    t = scene.triangles
    lo, hi = scene.bounds.astype(np.float64)
    center, extent = (lo + hi) / 2, np.linalg.norm(hi - lo)
    origins = center + rng.normal(size=(n, 3)) * extent
    inside = rng.random(n) < 0.2
    origins[inside] = rng.uniform(lo, hi, size=(inside.sum(), 3))
    target = v[t[rng.integers(0, len(t), n)]].mean(axis=1)
    directions = target - origins
    random = rng.random(n) < 0.15
    directions[random] = rng.normal(size=(random.sum(), 3))
    axis = rng.random(n) < 0.05
    k = rng.integers(0, 3, axis.sum())
    d = np.zeros((axis.sum(), 3))
    d[np.arange(len(k)), k] = rng.choice([-1.0, 1.0], len(k))
    directions[axis] = d
    return np.concatenate([origins, directions], axis=1).astype(np.float32)


@pytest.fixture(scope="session")
def chess() -> raytree.Scene:
    return raytree.Scene.builtin("chess:3000")


@pytest.fixture(scope="session")
def soup() -> raytree.Scene:
    """300 random triangles of all sizes and orientations, some sharing
    vertices, one degenerate."""
    rng = np.random.default_rng(3)
    vertices = rng.normal(size=(400, 3)) * 10
    triangles = rng.integers(0, 400, size=(300, 3))
    triangles[0] = [5, 5, 6]  # degenerate: never hit
    return raytree.Scene.from_arrays(vertices, triangles, name="soup")


def shared_mesh(name: str) -> raytree.Scene:
    path = SHARED / name
    if not path.exists():
        pytest.skip(f"{path} is not present")
    return raytree.Scene.load(path)


@pytest.fixture(scope="session")
def threads() -> int:
    """Worker threads for the heavier tests."""
    return max(2, os.cpu_count() or 1)
