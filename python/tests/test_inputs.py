"""Arrays in Python terms: any leading shape, any real dtype, no copy of
float32/float64 C-contiguous rays, the GIL released; every wrong input is a
TypeError or ValueError that says what is wrong, never a crash."""

from __future__ import annotations

import sys
import threading
import time
import tracemalloc

import numpy as np
import pytest

import raytree
from conftest import make_rays


@pytest.fixture(scope="module")
def accel(chess):
    return raytree.Accelerator(chess, "bvh")


@pytest.fixture(scope="module")
def rays(chess):
    return make_rays(chess, 600)


def test_leading_shapes(accel, rays):
    flat = accel.cast_rays(rays)
    for shape in [(600,), (20, 30), (2, 3, 100), (600, 1)]:
        ans = accel.cast_rays(rays.reshape(*shape, 6))
        assert ans["t_hit"].shape == shape
        assert ans["primitive_ids"].shape == shape
        assert ans["primitive_uvs"].shape == (*shape, 2)
        assert ans["primitive_normals"].shape == (*shape, 3)
        np.testing.assert_array_equal(ans["t_hit"].reshape(-1), flat["t_hit"])
        assert accel.test_occlusions(rays.reshape(*shape, 6)).shape == shape
        assert accel.count_intersections(rays.reshape(*shape, 6)).shape == shape
        counted = accel.cast_rays(rays.reshape(*shape, 6), counters=True)
        assert counted["nodes"].shape == shape
    one = accel.cast_rays(rays[5])
    assert one["t_hit"].shape == () and one["primitive_uvs"].shape == (2,)
    assert one["t_hit"] == flat["t_hit"][5]
    none = accel.cast_rays(np.zeros((0, 6), np.float32))
    assert none["t_hit"].shape == (0,)
    empty = accel.list_intersections(np.zeros((0, 4, 6)))
    assert empty["ray_splits"].tolist() == [0] and empty["t_hit"].shape == (0,)


def test_dtypes_and_layouts(accel, rays):
    want = accel.cast_rays(rays)
    as64 = rays.astype(np.float64)
    strided = np.zeros((600, 12), np.float32)
    strided[:, ::2] = rays
    variants = {
        "float64": as64,
        "float16": rays.astype(np.float16),
        "big-endian": rays.astype(">f4"),
        "fortran": np.asfortranarray(rays),
        "strided": strided[:, ::2],
        "every other": np.repeat(rays, 2, axis=0)[::2],
        "list": rays.tolist(),
        "int": np.round(rays * 4).astype(np.int32),
    }
    for name, r in variants.items():
        ans = accel.cast_rays(r)
        if name in ("float16", "int"):
            # Other rays: only check they traced.
            assert ans["t_hit"].shape == (600,), name
            continue
        if name == "float64":
            # Rounded to float32 ray by ray: the same rays.
            np.testing.assert_array_equal(ans["t_hit"], want["t_hit"], err_msg=name)
            continue
        for key in want:
            np.testing.assert_array_equal(ans[key], want[key], err_msg=name)
    # float64 rays with values that round: traced as their float32 rounding.
    np.testing.assert_array_equal(
        accel.cast_rays(as64 + 1e-12)["primitive_ids"], want["primitive_ids"]
    )
    # A read-only array is fine.
    ro = rays.copy()
    ro.flags.writeable = False
    np.testing.assert_array_equal(accel.cast_rays(ro)["t_hit"], want["t_hit"])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_contiguous_rays_are_not_copied(chess, dtype):
    accel = raytree.Accelerator(chess, "bvh")
    rays = np.ascontiguousarray(np.tile(make_rays(chess, 1000), (200, 1)), dtype=dtype)
    accel.cast_rays(rays[:10])
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        ans = accel.cast_rays(rays)
        peak = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    outputs = sum(a.nbytes for a in ans.values())
    # The outputs, and nothing the size of the rays besides.
    assert outputs <= peak < outputs + rays.nbytes // 4, (peak, outputs, rays.nbytes)


def test_the_gil_is_released(chess):
    accel = raytree.Accelerator(chess, "brute")
    rays = make_rays(chess, 15000)  # about 0.3 s on one thread
    ticks = []
    done = threading.Event()

    def trace():
        accel.cast_rays(rays, threads=1)
        done.set()

    worker = threading.Thread(target=trace)
    start = time.perf_counter()
    worker.start()
    while not done.is_set():
        ticks.append(time.perf_counter())
        time.sleep(0.001)
    worker.join()
    elapsed = time.perf_counter() - start
    assert elapsed > 0.05, "too quick to tell"
    # With the GIL held the loop would not run until the call returned.
    assert len(ticks) > 10 and ticks[-1] - ticks[0] > elapsed / 2


def test_ray_errors(accel, rays):
    with pytest.raises(ValueError, match=r"rays must have shape \(\.\.\., 6\).*\(600, 3\)"):
        accel.cast_rays(rays[:, :3])
    with pytest.raises(ValueError, match=r"shape \(5,\)"):
        accel.test_occlusions(np.zeros(5))
    with pytest.raises(ValueError, match=r"shape \(\)"):
        accel.count_intersections(np.float32(1.0))
    with pytest.raises(TypeError, match="real numbers.*<U"):
        accel.cast_rays(np.array([["a"] * 6]))
    with pytest.raises(TypeError, match="complex"):
        accel.cast_rays(rays.astype(np.complex64))
    with pytest.raises(TypeError, match="bool"):
        accel.cast_rays(rays > 0)
    with pytest.raises(TypeError):
        accel.cast_rays("rays")
    with pytest.raises(TypeError, match="rays must be a numpy array or convertible"):
        accel.cast_rays([[1, 2, 3, 4, 5, 6], [1, 2]])
    bad = rays.reshape(20, 30, 6).copy()
    bad[3, 7, 4] = np.nan
    for query in (
        accel.cast_rays,
        accel.test_occlusions,
        accel.count_intersections,
        accel.list_intersections,
    ):
        with pytest.raises(ValueError, match=r"rays\[3, 7\] cannot be traced: a NaN or infinite"):
            query(bad)
    # Opting in: such rays are misses, the others answered.
    ans = accel.cast_rays(bad, invalid_rays="miss")
    assert ans["primitive_ids"][3, 7] == raytree.INVALID_ID
    good = accel.cast_rays(rays.reshape(20, 30, 6))
    mask = np.ones((20, 30), bool)
    mask[3, 7] = False
    np.testing.assert_array_equal(ans["t_hit"][mask], good["t_hit"][mask])
    zero = rays.copy()
    zero[9, 3:] = 0
    with pytest.raises(ValueError, match=r"rays\[9\] cannot be traced: a zero direction"):
        accel.cast_rays(zero)
    far = rays.astype(np.float64)
    far[2, 0] = 1e39  # beyond float32: infinite once rounded
    with pytest.raises(ValueError, match=r"rays\[2\].*NaN or infinite"):
        accel.cast_rays(far)
    with pytest.raises(ValueError, match="a NaN tmin or tmax"):
        accel.cast_rays(rays, tmin=np.nan)
    with pytest.raises(ValueError, match=r"rays\[0\] cannot be traced: a negative tmin"):
        accel.cast_rays(rays, tmin=-1.0)
    assert np.isinf(accel.cast_rays(rays, tmin=-1.0, invalid_rays="miss")["t_hit"]).all()
    with pytest.raises(ValueError, match="invalid_rays must be 'raise' or 'miss'"):
        accel.cast_rays(rays, invalid_rays="ignore")
    with pytest.raises(ValueError, match=r"tmax of shape \(7,\) does not broadcast to the rays' leading shape \(600,\)"):
        accel.cast_rays(rays, tmax=np.ones(7))
    with pytest.raises(TypeError, match="tmin"):
        accel.cast_rays(rays, tmin="zero")
    for bad_threads in (-1, 5000):
        with pytest.raises(ValueError, match="threads must be"):
            accel.cast_rays(rays, threads=bad_threads)
    with pytest.raises(ValueError, match="max_hits"):
        accel.list_intersections(rays, max_hits=-1)


def test_build_errors(chess):
    with pytest.raises(ValueError, match=r"unknown structure 'bvh16' \(known: bvh, dst"):
        raytree.Accelerator(chess, "bvh16")
    with pytest.raises(ValueError, match=r"unknown traversal 'laine-3' \(known: stack"):
        raytree.Accelerator(chess, "bvh/laine-3")
    with pytest.raises(ValueError, match="applies to the 'bvh' structure only"):
        raytree.Accelerator(chess, "dst", traversal="sparse")
    with pytest.raises(ValueError, match="given twice"):
        raytree.Accelerator(chess, "bvh/sparse", traversal="hapala")
    with pytest.raises(ValueError, match=r"unknown builder 'ploc' \(known: sah, hybrid, sbvh, lbvh\)"):
        raytree.Accelerator(chess, builder="ploc")
    for size in (0, 256):
        with pytest.raises(ValueError, match=r"max_leaf_size must be in 1..=255"):
            raytree.Accelerator(chess, max_leaf_size=size)
    for block in (0, 3, 32, -4):
        with pytest.raises(ValueError, match=r"sah_block must be 1, 2, 4, 8 or 16, not"):
            raytree.Accelerator(chess, sah_block=block)
    with pytest.raises(TypeError, match="scene must be a raytree.Scene"):
        raytree.Accelerator(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="threads"):
        raytree.Accelerator(chess, threads=-2)


def test_scene_from_arrays():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float64)
    t = np.array([[0, 1, 2], [0, 2, 3]])
    for tt in (t, t.astype(np.uint8), t.astype(np.uint64), t.astype(np.int16), t.tolist()):
        scene = raytree.Scene.from_arrays(v, tt)
        assert scene.triangle_count == len(scene) == 2 and scene.vertex_count == 4
        np.testing.assert_array_equal(scene.triangles, t)
        assert scene.triangles.dtype == np.uint32
    scene = raytree.Scene.from_arrays(v.astype(np.float32), t, name="quad")
    assert scene.vertices.dtype == np.float32 and scene.vertices.shape == (4, 3)
    np.testing.assert_array_equal(scene.bounds, [[0, 0, 0], [1, 1, 0]])
    assert repr(scene) == 'Scene("quad", 2 triangles, 4 vertices)'
    # Down the z axis through the quad's middle: triangle 0 or 1 at t = 1.
    ans = raytree.Accelerator(scene).cast_rays([0.75, 0.25, 1, 0, 0, -1])
    assert ans["t_hit"] == 1 and ans["primitive_ids"] == 0
    np.testing.assert_allclose(ans["primitive_normals"], [0, 0, 1])


def test_scene_errors():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float64)
    t = np.array([[0, 1, 2], [0, 2, 3]])
    with pytest.raises(ValueError, match=r"vertices must have shape \(N, 3\), got shape \(4, 2\)"):
        raytree.Scene.from_arrays(v[:, :2], t)
    with pytest.raises(ValueError, match=r"triangles must have shape \(M, 3\), got shape \(6,\)"):
        raytree.Scene.from_arrays(v, t.reshape(-1))
    with pytest.raises(TypeError, match="triangles must be an array of integers.*float64"):
        raytree.Scene.from_arrays(v, t.astype(np.float64))
    with pytest.raises(TypeError, match="vertices must be an array of real numbers"):
        raytree.Scene.from_arrays(v.astype(str), t)
    with pytest.raises(ValueError, match=r"triangles\[1, 2\] = 4 is not a vertex index: there are 4 vertices"):
        raytree.Scene.from_arrays(v, [[0, 1, 2], [0, 2, 4]])
    with pytest.raises(ValueError, match=r"triangles\[0, 0\] = -1 is not a vertex index"):
        raytree.Scene.from_arrays(v, [[-1, 1, 2]])
    with pytest.raises(ValueError, match=r"triangles\[0, 1\] = 18446744073709551615"):
        raytree.Scene.from_arrays(v, np.array([[0, 2**64 - 1, 2]], dtype=np.uint64))
    nan = v.copy()
    nan[2, 1] = np.nan
    with pytest.raises(ValueError, match=r"vertices\[2\] has a non-finite coordinate"):
        raytree.Scene.from_arrays(nan, t)
    big = v.copy()
    big[3, 0] = 1e38
    with pytest.raises(ValueError, match=r"vertices\[3\] has a coordinate beyond"):
        raytree.Scene.from_arrays(big, t)
    with pytest.raises(ValueError, match="no triangles"):
        raytree.Scene.from_arrays(v, np.zeros((0, 3), int))
    with pytest.raises(ValueError, match="degenerate"):
        raytree.Scene.from_arrays(v, [[0, 1, 1], [2, 2, 2]])
    with pytest.raises(TypeError):
        raytree.Scene.from_arrays(v)


def test_scene_files(tmp_path):
    obj = tmp_path / "quad.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    scene = raytree.Scene.load(obj)
    assert scene.triangle_count == 2 and scene.name.endswith("quad.obj")
    assert raytree.Scene.load(str(obj)).triangle_count == 2
    # Several files: one scene, one geometry each, triangles numbered on.
    stl = tmp_path / "tri.stl"
    stl.write_text(
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 2\nvertex 1 0 2\nvertex 0 1 2\n"
        "endloop\nendfacet\nendsolid t\n"
    )
    both = raytree.Scene.load([obj, stl])
    assert both.triangle_count == 3 and "2 geometries" in repr(both)
    assert [(g["first_triangle"], g["triangle_count"]) for g in both.geometries] == [(0, 2), (2, 1)]
    assert both.geometries[1]["name"].endswith("tri.stl")
    ans = raytree.Accelerator(both).cast_rays([[0.2, 0.1, 5, 0, 0, -1], [0.6, 0.1, 1, 0, 0, -1]])
    assert ans["primitive_ids"].tolist() == [2, 0] and ans["geometry_ids"].tolist() == [1, 0]
    lists = raytree.Accelerator(both, "bvh4").list_intersections([0.2, 0.1, 5, 0, 0, -1])
    assert lists["primitive_ids"].tolist() == [2, 0] and lists["geometry_ids"].tolist() == [1, 0]
    g, local = both.geometry_of(np.array([[2, 0], [1, raytree.INVALID_ID]], dtype=np.uint32))
    assert g.tolist() == [[1, 0], [0, raytree.INVALID_ID]]
    assert local.tolist() == [[0, 0], [1, raytree.INVALID_ID]]
    assert both.geometry_of([-1, 3])[0].tolist() == [raytree.INVALID_ID] * 2
    with pytest.raises(TypeError, match="path must be"):
        raytree.Scene.load(3)
    with pytest.raises(ValueError, match="no mesh files"):
        raytree.Scene.load([])
    with pytest.raises(FileNotFoundError, match="missing.obj"):
        raytree.Scene.load(tmp_path / "missing.obj")
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nf 1 2 3\n")
    with pytest.raises(ValueError, match=r"bad.obj:2"):
        raytree.Scene.load(bad)
    other = tmp_path / "mesh.xyz"
    other.write_text("0 0 0\n")
    with pytest.raises(ValueError, match="unknown mesh format"):
        raytree.Scene.load(other)
    assert raytree.Scene.builtin("hairball:2000").triangle_count > 1000
    with pytest.raises(ValueError, match="unknown"):
        raytree.Scene.builtin("teapot")


def test_names():
    assert raytree.STRUCTURES[0] == "bvh" and raytree.STRUCTURES[-1] == "brute"
    assert {"dst", "dst-similar", "bih", "htree", "cbvh", "bvh4", "bvh8"} <= set(raytree.STRUCTURES)
    assert "laine-4" in raytree.TRAVERSALS and raytree.TRAVERSALS[0] == "stack"
    assert raytree.BUILDERS == ("sah", "hybrid", "sbvh", "lbvh")
    assert raytree.INVALID_ID == 0xFFFFFFFF
    assert sys.modules["raytree._raytree"].__version__ == raytree.__version__
