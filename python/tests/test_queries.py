"""Every structure and traversal answers every query as the oracle does (the
``brute`` structure, and an independent numpy brute force), ray for ray."""

from __future__ import annotations

import functools
import itertools

import numpy as np
import pytest

import raytree
from conftest import CONFIGURATIONS, make_rays, shared_mesh


def oracle(scene: raytree.Scene) -> raytree.Accelerator:
    return raytree.Accelerator(scene, "brute")


def assert_same_closest(got: dict, want: dict, what: str) -> None:
    for key in ("t_hit", "primitive_ids", "geometry_ids", "primitive_uvs", "primitive_normals"):
        np.testing.assert_array_equal(got[key], want[key], err_msg=f"{what}: {key}")


def assert_same_lists(got: dict, want: dict, what: str) -> None:
    for key in ("ray_splits", "ray_ids", "t_hit", "primitive_ids", "primitive_uvs"):
        np.testing.assert_array_equal(got[key], want[key], err_msg=f"{what}: {key}")


@pytest.mark.parametrize("builder", ["sah", "hybrid", "sbvh", "lbvh"])
@pytest.mark.parametrize("scene_name", ["chess", "soup"])
def test_every_structure_agrees_with_the_oracle(scene_name, builder, request):
    scene = request.getfixturevalue(scene_name)
    rays = make_rays(scene, 3000)
    # Some rays end early, some start late.
    tmax = np.where(np.arange(len(rays)) % 7 == 0, 0.5, np.inf).astype(np.float32)
    tmin = np.where(np.arange(len(rays)) % 11 == 0, 0.3, 0.0).astype(np.float32)
    brute = oracle(scene)
    want = brute.cast_rays(rays, tmin, tmax)
    want_any = brute.test_occlusions(rays, tmin, tmax)
    want_count = brute.count_intersections(rays, tmin, tmax)
    want_list = brute.list_intersections(rays, tmin, tmax)
    hits = (want["primitive_ids"] != raytree.INVALID_ID).mean()
    assert 0.3 < hits < 0.95, hits
    assert want_count.max() >= 2
    for name in CONFIGURATIONS:
        accel = raytree.Accelerator(scene, name, builder=builder, max_leaf_size=4)
        what = f"{scene_name} {name} {builder}"
        assert_same_closest(accel.cast_rays(rays, tmin, tmax), want, what)
        np.testing.assert_array_equal(accel.test_occlusions(rays, tmin, tmax), want_any, what)
        np.testing.assert_array_equal(
            accel.count_intersections(rays, tmin, tmax), want_count, what
        )
        assert_same_lists(accel.list_intersections(rays, tmin, tmax), want_list, what)
    # SAH costs in blocks of four triangles: another tree, the same answers.
    for name in ["bvh", "bvh8", "cwbvh", "dst"]:
        accel = raytree.Accelerator(scene, name, builder=builder, sah_block=4)
        what = f"{scene_name} {name} {builder} sah_block=4"
        assert accel.info()["bvh"]["sah_block"] == 4
        assert_same_closest(accel.cast_rays(rays, tmin, tmax), want, what)
        np.testing.assert_array_equal(accel.test_occlusions(rays, tmin, tmax), want_any, what)


@pytest.mark.parametrize("mesh", ["teapot.obj", "bunny.obj"])
def test_shared_meshes_agree_with_the_oracle(mesh, threads):
    scene = shared_mesh(mesh)
    rays = make_rays(scene, 600, seed=11)
    brute = oracle(scene)
    want = brute.cast_rays(rays, threads=threads)
    want_any = brute.test_occlusions(rays, threads=threads)
    want_list = brute.list_intersections(rays, threads=threads)
    want_count = np.diff(want_list["ray_splits"]).astype(np.uint32)
    for name in CONFIGURATIONS:
        accel = raytree.Accelerator(scene, name, threads=threads)
        what = f"{mesh} {name}"
        assert_same_closest(accel.cast_rays(rays, threads=threads), want, what)
        np.testing.assert_array_equal(accel.test_occlusions(rays, threads=threads), want_any)
        np.testing.assert_array_equal(
            accel.count_intersections(rays, threads=threads), want_count, what
        )
        assert_same_lists(accel.list_intersections(rays, threads=threads), want_list, what)


def numpy_hits(vertices, triangles, rays):
    """Every (ray, triangle, t, u, v) by Möller–Trumbore in float64, rays
    over [0, inf)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    o, d = rays[:, None, :3], rays[:, None, 3:]
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = np.einsum("rtk,tk->rt", p, e1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o - a
        u = np.einsum("rtk,rtk->rt", s, p) * inv
        q = np.cross(s, e1)
        v = np.einsum("rtk,rtk->rt", d, q) * inv
        t = np.einsum("tk,rtk->rt", e2, q) * inv
    hit = (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0)
    return hit, t, u, v


def test_agrees_with_a_numpy_brute_force(soup):
    v = soup.vertices.astype(np.float64)
    tris = soup.triangles.astype(np.int64)
    rays = make_rays(soup, 400, seed=5)
    hit, t, u, v_ = numpy_hits(v, tris, rays.astype(np.float64))
    accel = raytree.Accelerator(soup, "dst")
    ans = accel.cast_rays(rays)
    t_np = np.where(hit, t, np.inf).min(axis=1)
    any_np = hit.any(axis=1)
    # Away from edges and ties both agree; allow float32 rounding.
    np.testing.assert_array_equal(accel.test_occlusions(rays), any_np)
    np.testing.assert_allclose(ans["t_hit"], t_np, rtol=1e-4, atol=1e-4)
    first = np.where(any_np, np.where(hit, t, np.inf).argmin(axis=1), -1)
    ids = ans["primitive_ids"].astype(np.int64)
    ids[ids == raytree.INVALID_ID] = -1
    assert (ids == first).mean() > 0.99
    np.testing.assert_array_equal(accel.count_intersections(rays), hit.sum(axis=1))
    # The hit point from the barycentrics lies on the ray at t_hit.
    r = ids >= 0
    a, b, c = (v[tris[ids[r], k]] for k in range(3))
    uv = ans["primitive_uvs"][r].astype(np.float64)
    point = (1 - uv[:, :1] - uv[:, 1:]) * a + uv[:, :1] * b + uv[:, 1:] * c
    along = rays[r, :3] + ans["t_hit"][r, None] * rays[r, 3:]
    scale = np.abs(point).max() + 1
    np.testing.assert_allclose(point, along, atol=1e-4 * scale)
    # Normals: unit, the triangle's (b-a)x(c-a).
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    np.testing.assert_allclose(ans["primitive_normals"][r], n, atol=1e-5)
    assert not ans["primitive_normals"][~r].any()
    assert not ans["primitive_uvs"][~r].any()
    assert (ans["geometry_ids"][r] == 0).all()
    assert (ans["geometry_ids"][~r] == raytree.INVALID_ID).all()


def test_threads_give_the_same_answers(chess):
    rays = make_rays(chess, 5000, seed=2)
    accel = raytree.Accelerator(chess, "bvh/sparse", threads=1)
    one = accel.cast_rays(rays, threads=1, counters=True)
    lists = accel.list_intersections(rays, threads=1, counters=True)
    for n in (2, 3, 8):
        many = accel.cast_rays(rays, threads=n, counters=True)
        for key in one:
            np.testing.assert_array_equal(one[key], many[key], err_msg=f"{n} threads: {key}")
        other = accel.list_intersections(rays, threads=n, counters=True)
        for key in lists:
            np.testing.assert_array_equal(lists[key], other[key], err_msg=f"{n} threads: {key}")
    built = raytree.Accelerator(chess, "dst", threads=3)
    assert built.info()["bytes"] == raytree.Accelerator(chess, "dst", threads=1).info()["bytes"]
    np.testing.assert_array_equal(built.cast_rays(rays)["t_hit"], one["t_hit"])


def test_counters(chess, soup):
    rays = make_rays(chess, 2000)
    bvh = raytree.Accelerator(chess, "bvh")
    plain = bvh.cast_rays(rays)
    counted = bvh.cast_rays(rays, counters=True)
    for key in plain:
        np.testing.assert_array_equal(plain[key], counted[key])
    hit = plain["primitive_ids"] != raytree.INVALID_ID
    assert (counted["nodes"][hit] >= 1).all()
    assert (counted["triangle_tests"][hit] >= 1).all()
    assert (counted["plane_tests"] % 6 == 0).all()  # a BVH tests boxes
    # The any-hit search stops at its first hit: never more work.
    occl = bvh.test_occlusions(rays, counters=True)
    np.testing.assert_array_equal(occl["occluded"], hit)
    assert (occl["nodes"] <= bvh.count_intersections(rays, counters=True)["nodes"]).all()
    # The dual-split tree tests planes, not boxes, and fewer of them.
    dst = raytree.Accelerator(chess, "dst").cast_rays(rays, counters=True)
    assert dst["plane_tests"].sum() < counted["plane_tests"].sum()
    # Brute force tests every triangle but the degenerate ones.
    brute = raytree.Accelerator(soup, "brute")
    srays = make_rays(soup, 100)
    v, tr = soup.vertices.astype(np.float64), soup.triangles
    area = np.cross(v[tr[:, 1]] - v[tr[:, 0]], v[tr[:, 2]] - v[tr[:, 0]])
    tested = int((np.abs(area).max(axis=1) > 0).sum())
    assert tested < soup.triangle_count
    for query in (brute.test_occlusions, brute.count_intersections):
        c = query(srays, counters=True)
        assert c["triangle_tests"].max() == tested
    lst = brute.list_intersections(srays, counters=True)
    assert (lst["triangle_tests"] == tested).all()
    assert lst["nodes"].shape == (100,)


def test_intervals(chess):
    rays = make_rays(chess, 2000)
    accel = raytree.Accelerator(chess, "bih")
    full = accel.cast_rays(rays)
    hit = full["primitive_ids"] != raytree.INVALID_ID
    t = full["t_hit"]
    # Just past the hit: found; just before it: not that one.
    after = accel.cast_rays(rays, tmax=np.where(hit, t * 1.001, np.inf))
    np.testing.assert_array_equal(after["primitive_ids"], full["primitive_ids"])
    before = accel.cast_rays(rays, tmax=np.where(hit, t * 0.999, np.inf))
    assert (before["primitive_ids"][hit] == raytree.INVALID_ID).all()
    # A later start finds the nearest listed hit at or after it.
    tmin = np.where(hit, t * np.float32(1.001), np.float32(0))
    later = accel.cast_rays(rays, tmin=tmin)
    lists = accel.list_intersections(rays)
    lt, rid = lists["t_hit"], lists["ray_ids"]
    ok = lt >= tmin[rid]
    want = np.full(len(rays), np.inf, dtype=np.float32)
    np.minimum.at(want, rid[ok], lt[ok])
    np.testing.assert_array_equal(later["t_hit"], want)
    assert (later["t_hit"] > t).sum() > 100
    # Scalars, 0-d arrays, per-ray arrays and broadcasting agree.
    a = accel.cast_rays(rays, tmax=50.0)
    b = accel.cast_rays(rays, tmax=np.float32(50))
    c = accel.cast_rays(rays, tmax=np.full(len(rays), 50.0))
    d = accel.cast_rays(rays.reshape(40, 50, 6), tmax=np.full((1, 50), 50.0))
    e = accel.cast_rays(rays, tmax=np.array(50.0))
    for other in (b, c, e):
        np.testing.assert_array_equal(a["t_hit"], other["t_hit"])
    np.testing.assert_array_equal(a["t_hit"], d["t_hit"].reshape(-1))
    assert (a["t_hit"][a["primitive_ids"] != raytree.INVALID_ID] <= 50).all()
    # tmin > tmax: an empty interval, a miss.
    empty = accel.cast_rays(rays, tmin=2.0, tmax=1.0)
    assert (empty["primitive_ids"] == raytree.INVALID_ID).all()


def test_list_intersections_layout_and_max_hits(chess):
    rays = make_rays(chess, 1500).reshape(30, 50, 6)
    accel = raytree.Accelerator(chess, "htree")
    lists = accel.list_intersections(rays)
    splits, ray_ids = lists["ray_splits"], lists["ray_ids"]
    assert splits.shape == (1501,) and splits[0] == 0 and splits[-1] == len(ray_ids)
    counts = accel.count_intersections(rays)
    np.testing.assert_array_equal(np.diff(splits), counts.reshape(-1))
    np.testing.assert_array_equal(ray_ids, np.repeat(np.arange(1500), np.diff(splits)))
    # Nearest first within each ray, and the first is cast_rays' answer.
    t = lists["t_hit"]
    same_ray = ray_ids[1:] == ray_ids[:-1]
    assert (t[1:][same_ray] >= t[:-1][same_ray]).all()
    first = accel.cast_rays(rays)
    has = np.diff(splits) > 0
    np.testing.assert_array_equal(
        lists["primitive_ids"][splits[:-1][has]], first["primitive_ids"].reshape(-1)[has]
    )
    assert lists["primitive_uvs"].shape == (len(t), 2)
    assert lists["primitive_normals"].shape == (len(t), 3)
    # max_hits keeps the nearest ones.
    two = accel.list_intersections(rays, max_hits=2)
    np.testing.assert_array_equal(np.diff(two["ray_splits"]), np.minimum(np.diff(splits), 2))
    keep = np.concatenate([np.arange(s, min(s + 2, e)) for s, e in zip(splits[:-1], splits[1:])])
    np.testing.assert_array_equal(two["t_hit"], t[keep.astype(np.int64)])
    none = accel.list_intersections(rays, max_hits=0)
    assert len(none["t_hit"]) == 0 and (none["ray_splits"] == 0).all()


def test_info(chess):
    for name in ["bvh", "bvh/implicit-b", "dst", "dst-similar", "bih", "htree", "cbvh", "brute"]:
        accel = raytree.Accelerator(chess, name, builder="hybrid", max_leaf_size=4)
        info = accel.info()
        assert info["structure"] == name.split("/")[0]
        assert info["bytes"] == accel.bytes == info["node_bytes"] + info["index_bytes"]
        assert info["triangles"] == chess.triangle_count
        assert info["bvh"]["builder"] == "hybrid" and info["bvh"]["max_leaf_size"] == 4
        assert info["bvh"]["sah_block"] == 1
        assert info["bvh"]["nodes"] == info["bvh"]["inner_nodes"] + info["bvh"]["leaves"]
        assert info["leaves"] >= 1
        if name.startswith("bvh"):
            assert info["traversal"] == accel.traversal == (name.split("/") + ["stack"])[1]
            assert info["state_bytes"] > 0
        else:
            assert info["traversal"] is None and accel.traversal is None
        if name.startswith("dst"):
            assert info["dst"]["split_nodes"] > 0
    # The wide trees build with SAH leaf costs per block of 4 unless told.
    for name in ["bvh4", "bvh8", "cwbvh"]:
        assert raytree.Accelerator(chess, name).info()["bvh"]["sah_block"] == 4
        assert raytree.Accelerator(chess, name, sah_block=1).info()["bvh"]["sah_block"] == 1
    assert raytree.Accelerator(chess, "bvh", sah_block=4).info()["bvh"]["sah_block"] == 4
    assert raytree.Accelerator(chess, "bvh", traversal="laine-4").traversal == "laine-4"
    assert "implicit" == raytree.Accelerator(chess, "bvh/implicit-a").info()["layout"]
    assert repr(raytree.Accelerator(chess, "bvh/hapala")).startswith('Accelerator("bvh/hapala"')
    assert raytree.Accelerator(chess).scene is not None


def test_large_batches_answer_as_small_ones(chess):
    # A batch of many chunks (1024 rays each, split between the threads)
    # answers as the same rays asked for in ten smaller batches, counters
    # included, and as the oracle.
    rays = make_rays(chess, 40_000, seed=4)
    pieces = np.array_split(rays, 10)
    brute = oracle(chess).cast_rays(rays)
    for name in ("bvh", "bvh/sparse", "bvh8", "dst"):
        accel = raytree.Accelerator(chess, name)
        for threads in (1, 2):
            for query, counters in itertools.product(
                ("cast_rays", "test_occlusions", "count_intersections"), (False, True)
            ):
                ask = functools.partial(getattr(accel, query), threads=threads, counters=counters)
                whole, parts = ask(rays), [ask(p) for p in pieces]
                if not isinstance(whole, dict):
                    whole, parts = {"value": whole}, [{"value": p} for p in parts]
                for key in whole:
                    joined = np.concatenate([p[key] for p in parts])
                    np.testing.assert_array_equal(whole[key], joined, err_msg=f"{name} {query} {counters} {key}")
            assert_same_closest(accel.cast_rays(rays, threads=threads), brute, name)
    # The smallest index of a ray that cannot be traced is named, whichever
    # chunk or thread met it first.
    bad = rays.copy()
    bad[[31_000, 20_123, 39_999], 3:] = 0
    accel = raytree.Accelerator(chess, "bvh8")
    with pytest.raises(ValueError, match=r"rays\[20123\] cannot be traced: a zero direction"):
        accel.cast_rays(bad)
    missed = accel.cast_rays(bad, invalid_rays="miss")
    keep = np.ones(len(rays), bool)
    keep[[31_000, 20_123, 39_999]] = False
    assert (missed["primitive_ids"][~keep] == raytree.INVALID_ID).all()
    np.testing.assert_array_equal(missed["t_hit"][keep], brute["t_hit"][keep])
