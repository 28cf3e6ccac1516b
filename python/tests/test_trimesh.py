"""raytree.RayMeshIntersector answers as trimesh's own intersector does, on
trimesh meshes (when trimesh is installed) and on any object with
``vertices`` and ``faces``."""

from __future__ import annotations

import numpy as np
import pytest

import raytree


class FakeMesh:
    """What the intersector needs of a mesh: vertices and faces."""

    def __init__(self, vertices, faces):
        self.vertices = np.asarray(vertices, dtype=np.float64)
        self.faces = np.asarray(faces, dtype=np.int64)


def two_quads() -> FakeMesh:
    # Two unit squares facing +z, at z = 0 and z = 1, two triangles each.
    v = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    v = v + [[x, y, 1] for x, y, _ in v]
    f = [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]]
    return FakeMesh(v, f)


def test_duck_typed_mesh():
    r = raytree.RayMeshIntersector(two_quads())
    origins = [[0.7, 0.2, 5], [0.2, 0.7, 5], [3, 3, 5], [0.2, 0.7, 0.5]]
    directions = [[0, 0, -1], [0, 0, -2], [0, 0, -1], [0, 0, 1]]
    first = r.intersects_first(origins, directions)
    assert first.dtype == np.int64
    assert first.tolist() == [2, 3, -1, 3]
    assert r.intersects_any(origins, directions).tolist() == [True, True, False, True]
    tri, ray = r.intersects_id(origins, directions)
    assert tri.tolist() == [2, 0, 3, 1, 3] and ray.tolist() == [0, 0, 1, 1, 3]
    tri, ray, loc = r.intersects_id(origins, directions, multiple_hits=False, return_locations=True)
    assert tri.tolist() == [2, 3, 3] and ray.tolist() == [0, 1, 3]
    np.testing.assert_allclose(loc, [[0.7, 0.2, 1], [0.2, 0.7, 1], [0.2, 0.7, 1]])
    loc, ray, tri = r.intersects_location(origins, directions)
    np.testing.assert_allclose(
        loc, [[0.7, 0.2, 1], [0.7, 0.2, 0], [0.2, 0.7, 1], [0.2, 0.7, 0], [0.2, 0.7, 1]]
    )
    assert r.intersects_id(origins, directions, max_hits=1)[0].tolist() == [2, 3, 3]
    # A ray down the shared diagonal meets both triangles of each quad: both
    # ids without locations, one point per quad with them (as trimesh).
    diag = ([[0.5, 0.5, 5]], [[0, 0, -1]])
    assert r.intersects_id(*diag)[0].tolist() == [2, 3, 0, 1]
    loc, ray, tri = r.intersects_location(*diag)
    assert tri.tolist() == [2, 0] and ray.tolist() == [0, 0]
    # Rays start at their origin.
    assert r.intersects_first([[0.5, 0.2, -1]], [[0, 0, -1]]).tolist() == [-1]
    # A zero direction hits nothing, as in trimesh.
    assert r.intersects_first([[0.5, 0.2, 5]], [[0, 0, 0]]).tolist() == [-1]
    # Empty queries.
    assert r.intersects_first(np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)
    assert r.intersects_location(np.zeros((0, 3)), np.zeros((0, 3)))[0].shape == (0, 3)


def test_errors():
    r = raytree.RayMeshIntersector(two_quads())
    with pytest.raises(ValueError, match="same shape"):
        r.intersects_first(np.zeros((3, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
        r.intersects_any(np.zeros((3, 2)), np.zeros((3, 2)))
    with pytest.raises(TypeError, match="unexpected keyword"):
        r.intersects_first(np.zeros((1, 3)), np.ones((1, 3)), tolerance=1)
    with pytest.raises(TypeError, match="object has no 'vertices'"):
        raytree.RayMeshIntersector(object())
    strict = raytree.RayMeshIntersector(two_quads(), invalid_rays="raise")
    with pytest.raises(ValueError, match="zero direction"):
        strict.intersects_first([[0.5, 0.2, 5]], [[0, 0, 0]])
    bad = raytree.RayMeshIntersector(FakeMesh([[0, 0, 0], [1, 0, 0], [0, 1, np.nan]], [[0, 1, 2]]))
    with pytest.raises(ValueError, match="non-finite"):
        bad.intersects_any([[0, 0, 1]], [[0, 0, -1]])


trimesh = pytest.importorskip("trimesh")


def meshes():
    yield "icosphere", trimesh.creation.icosphere(subdivisions=3)
    yield "box", trimesh.creation.box(extents=[1, 2, 3])
    torus = trimesh.creation.torus(major_radius=1.0, minor_radius=0.3)
    yield "torus", torus
    yield "annulus", trimesh.creation.annulus(r_min=0.5, r_max=1.0, height=0.5)


def random_rays(mesh, n, seed=0):
    rng = np.random.default_rng(seed)
    lo, hi = mesh.bounds
    origins = rng.uniform(lo - 1, hi + 1, size=(n, 3))
    targets = rng.uniform(lo, hi, size=(n, 3))
    return origins, targets - origins


@pytest.mark.parametrize("name,mesh", list(meshes()), ids=lambda x: x if isinstance(x, str) else "")
def test_agrees_with_trimesh(name, mesh):
    ours = raytree.RayMeshIntersector(mesh)
    theirs = trimesh.ray.ray_triangle.RayMeshIntersector(mesh)
    origins, directions = random_rays(mesh, 500)
    first = ours.intersects_first(origins, directions)
    their_first = theirs.intersects_first(origins, directions)
    # trimesh tests in float64 with a tolerance; edges and ties may differ.
    assert (first == their_first).mean() > 0.98
    np.testing.assert_array_equal(
        ours.intersects_any(origins, directions), theirs.intersects_any(origins, directions)
    )
    loc, ray, tri = ours.intersects_location(origins, directions)
    their_loc, their_ray, their_tri = theirs.intersects_location(origins, directions)
    np.testing.assert_array_equal(
        np.bincount(ray, minlength=500), np.bincount(their_ray, minlength=500)
    )
    ours_sorted = np.lexsort((tri, ray))
    theirs_sorted = np.lexsort((their_tri, their_ray))
    np.testing.assert_allclose(loc[ours_sorted], their_loc[theirs_sorted], atol=1e-5)
    # Inside tests through trimesh's own parity code over our queries.
    points = np.random.default_rng(1).uniform(*mesh.bounds, size=(300, 3))
    np.testing.assert_array_equal(ours.contains_points(points), mesh.contains(points))


def test_sah_block_reaches_the_build_and_keeps_the_answers():
    mesh = trimesh.creation.torus(major_radius=1.0, minor_radius=0.3)
    origins, directions = random_rays(mesh, 500, seed=2)
    plain = raytree.RayMeshIntersector(mesh, structure="bvh8", sah_block=1)
    blocks = raytree.RayMeshIntersector(mesh, structure="bvh8")
    assert plain.accelerator.info()["bvh"]["sah_block"] == 1
    # The wide trees' default: SAH leaf costs per block of 4.
    assert blocks.accelerator.info()["bvh"]["sah_block"] == 4
    assert raytree.RayMeshIntersector(mesh).accelerator.info()["bvh"]["sah_block"] == 1
    np.testing.assert_array_equal(
        blocks.intersects_first(origins, directions), plain.intersects_first(origins, directions)
    )
    np.testing.assert_array_equal(
        blocks.intersects_any(origins, directions), plain.intersects_any(origins, directions)
    )
    with pytest.raises(ValueError, match="sah_block must be"):
        raytree.RayMeshIntersector(mesh, sah_block=3).intersects_any(origins, directions)


def test_one_line_change():
    mesh = trimesh.creation.icosphere()
    origins, directions = random_rays(mesh, 200, seed=4)
    before = mesh.ray.intersects_location(origins, directions, multiple_hits=False)
    mesh.ray = raytree.RayMeshIntersector(mesh)
    after = mesh.ray.intersects_location(origins, directions, multiple_hits=False)
    # trimesh lists them in its own order, raytree ray by ray.
    order = np.argsort(before[1])
    np.testing.assert_array_equal(before[1][order], after[1])
    np.testing.assert_array_equal(before[2][order], after[2])
    np.testing.assert_allclose(before[0][order], after[0], atol=1e-5)
    # trimesh's own methods that trace through mesh.ray.
    points = np.random.default_rng(2).uniform(-1.2, 1.2, size=(200, 3))
    inside = mesh.contains(points)
    radius = np.linalg.norm(points, axis=1)
    assert inside[radius < 0.9].all() and not inside[radius > 1.01].any()
    # A changed mesh is rebuilt.
    mesh.apply_translation([10, 0, 0])
    moved = mesh.ray.intersects_any(origins + [10, 0, 0], directions)
    np.testing.assert_array_equal(moved, np.isin(np.arange(200), after[1]))
