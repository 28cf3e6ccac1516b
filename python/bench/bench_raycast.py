#!/usr/bin/env python3
"""Closest-hit throughput from Python: raytree's ``cast_rays`` against the
core's own batch call (the Python overhead), Open3D's
``RaycastingScene.cast_rays``, embreex and trimesh's default pure-numpy
intersector, on the same rays, on one thread and on all threads.

Each contender is used when its package imports and skipped with a note
otherwise (``pip install open3d embreex trimesh rtree``). Builds are not
timed; every timed query ran once before (warm caches, lazily built
structures). Rays (``--kind sphere``, the default): ``--rays`` from a
sphere around the mesh (twice its bounding radius) towards uniform points
of its box, float32, tmin 0, tmax inf, in no order; about half hit on a
closed mesh. ``--kind camera``: a pinhole camera's rays row by row, the
coherent case. The contenders take turns, round
after round (``--repeats``; trimesh's slow intersector runs once), and the
least wall-clock time and the least CPU time (this process and its children,
all threads) of each count, so that a busy moment hurts every contender
alike; on a shared machine the CPU seconds are the steadier figure. Agreement: the fraction of rays whose triangle (or miss) equals
raytree's.

    python python/bench/bench_raycast.py --scene ../shared/scenes/dragon.obj

``--cli PATH`` also times the route raytree offered Python before this
package: write a ray file, run ``raytree trace`` (which loads the mesh and
builds the tree on every call), read the hit file back.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# numpy's BLAS threads spin for a while after each call that uses them
# (the rays are made with numpy, and trimesh's intersector is numpy),
# taking a core from whichever contender is timed next on a small
# machine; the contenders' own threads do not use BLAS.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import raytree


RUST = "raytree Rust batch (Ray::new + Tracer::intersect)"


def make_rays(scene: raytree.Scene, n: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo, hi = scene.bounds.astype(np.float64)
    center, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    d = rng.normal(size=(n, 3))
    origins = center + 2 * radius * d / np.linalg.norm(d, axis=1, keepdims=True)
    targets = rng.uniform(lo, hi, size=(n, 3))
    return np.concatenate([origins, targets - origins], axis=1).astype(np.float32)


def make_camera_rays(scene: raytree.Scene, n: int) -> np.ndarray:
    """About n rays of a pinhole camera (a square image, row by row, one ray
    through each pixel's center), float32: from outside the mesh's box
    (1.2 bounding diagonals from its center, above and to one side) towards
    its center, 45° across. Coherent: neighbours start at one point and
    point nearly alike."""
    lo, hi = scene.bounds.astype(np.float64)
    center, diagonal = (lo + hi) / 2, np.linalg.norm(hi - lo)
    eye = center + 1.2 * diagonal * np.array([0.3, 0.4, 0.866]) / np.linalg.norm([0.3, 0.4, 0.866])
    forward = (center - eye) / np.linalg.norm(center - eye)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    side = int(np.sqrt(n))
    ys, xs = np.mgrid[0:side, 0:side]
    extent = np.tan(np.radians(45.0) / 2)
    px = ((xs.reshape(-1, 1) + 0.5) / side * 2 - 1) * extent
    py = (1 - (ys.reshape(-1, 1) + 0.5) / side * 2) * extent
    d = forward + px * right + py * up
    return np.concatenate([np.broadcast_to(eye, d.shape), d], axis=1).astype(np.float32)


def best(fn, repeats: int) -> tuple[float, float]:
    """The least wall-clock seconds and the least CPU seconds (this process,
    all threads) of `repeats` calls."""
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        fn()
        cpu.append(time.process_time() - start_cpu)
        wall.append(time.perf_counter() - start)
    return min(wall), min(cpu)


def agreement(ids: np.ndarray, reference: np.ndarray) -> float:
    return float((ids.astype(np.int64) == reference.astype(np.int64)).mean())


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", default="chess:1M", help="mesh file or built-in scene (default chess:1M)")
    p.add_argument("--rays", type=int, default=1_000_000)
    p.add_argument(
        "--kind",
        choices=["sphere", "camera"],
        default="sphere",
        help="sphere: from random points around the mesh towards random points of its box, in no "
        "order (incoherent; the default); camera: a pinhole camera's rays, row by row (coherent)",
    )
    p.add_argument("--threads", default=f"1,{os.cpu_count()}", help="thread counts, comma-separated")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument(
        "--structure", default="bvh8", help="raytree structure[/traversal] (default bvh8, the fastest)"
    )
    p.add_argument(
        "--sah-block",
        type=int,
        default=None,
        choices=[1, 2, 4, 8, 16],
        help="raytree's SAH leaf cost per block of this many triangles (default: the "
        "Accelerator's, 4 for bvh4/bvh8/cwbvh, whose leaves test four triangles at a time, "
        "as Embree's sahBlockSize, and 1 for the others)",
    )
    p.add_argument(
        "--trimesh-rays",
        type=int,
        default=100,
        help="rays for trimesh's pure-numpy intersector, traced 10 at a time (it is slow, and "
        "its memory grows with the triangles whose boxes each ray's box meets); 0 skips it",
    )
    p.add_argument("--cli", help="path of a built `raytree` binary: also time the ray-file route")
    args = p.parse_args()
    if args.rays < 1 or args.repeats < 1:
        p.error("--rays and --repeats must be at least 1")
    try:
        threads = [int(t) for t in args.threads.split(",")]
    except ValueError:
        p.error(f"--threads: not a comma-separated list of counts: {args.threads!r}")
    if any(t < 1 for t in threads):
        p.error("--threads: every count must be at least 1")

    if Path(args.scene).exists():
        scene = raytree.Scene.load(args.scene)
    else:
        scene = raytree.Scene.builtin(args.scene)
    rays = make_rays(scene, args.rays) if args.kind == "sphere" else make_camera_rays(scene, args.rays)
    n = len(rays)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"# {scene.name}: {scene.triangle_count} triangles, {n} {args.kind} rays, best of {args.repeats}")
    print(
        f"# {platform.processor() or platform.machine()}, {os.cpu_count()} logical cores, "
        f"load average {load:.2f} at start, Python {platform.python_version()}, numpy {np.__version__}"
    )

    start = time.perf_counter()
    accel = raytree.Accelerator(scene, args.structure, sah_block=args.sah_block)
    print(
        f"# raytree {args.structure} (SAH leaf cost per block of {accel.info()['bvh']['sah_block']}): "
        f"built in {time.perf_counter() - start:.2f} s"
    )
    reference = accel.cast_rays(rays)["primitive_ids"]
    hits = int((reference != raytree.INVALID_ID).sum())
    print(f"# {hits / n:.1%} of the rays hit")

    contenders = {}  # name -> (callable(threads) -> seconds, thread counts it honours)

    def raytree_python(t):
        return best(lambda: accel.cast_rays(rays, threads=t), 1)

    trace_alone = {}  # threads -> least (wall, cpu) of the Rust trace without building the rays

    def raytree_rust(t):
        wall, cpu, trace_wall, trace_cpu, _ = accel._rust_batch(rays, threads=t)
        old = trace_alone.get(t, (np.inf, np.inf))
        trace_alone[t] = (min(old[0], trace_wall), min(old[1], trace_cpu))
        return wall, cpu

    contenders["raytree cast_rays (Python)"] = (raytree_python, threads)
    contenders[RUST] = (raytree_rust, threads)
    ids = {}

    notes = []
    try:
        import open3d as o3d

        o3d_scene = o3d.t.geometry.RaycastingScene()
        o3d_scene.add_triangles(
            o3d.core.Tensor(scene.vertices), o3d.core.Tensor(scene.triangles.astype(np.uint32))
        )
        o3d_rays = o3d.core.Tensor(rays)
        ids["Open3D"] = o3d_scene.cast_rays(o3d_rays)["primitive_ids"].numpy()

        def open3d(t):
            return best(lambda: o3d_scene.cast_rays(o3d_rays, nthreads=t), 1)

        contenders[f"Open3D {o3d.__version__} RaycastingScene.cast_rays"] = (open3d, threads)
        ids[f"Open3D {o3d.__version__} RaycastingScene.cast_rays"] = ids.pop("Open3D")
    except Exception as e:  # ImportError, or a missing system library
        notes.append(f"Open3D skipped: {e}")
    try:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        em = rtcore_scene.EmbreeScene()
        TriangleMesh(scene=em, vertices=scene.vertices, indices=scene.triangles.astype(np.int32))
        o, d = np.ascontiguousarray(rays[:, :3]), np.ascontiguousarray(rays[:, 3:])
        found = em.run(o, d)
        ids["embreex"] = np.where(found < 0, np.int64(raytree.INVALID_ID), found.astype(np.int64))

        def embree(t):
            return best(lambda: em.run(o, d), 1)

        # embreex traces its batch on the calling thread.
        contenders["embreex rtcore_scene.run (one thread)"] = (embree, [1])
        ids["embreex rtcore_scene.run (one thread)"] = ids.pop("embreex")
    except Exception as e:
        notes.append(f"embreex skipped: {e}")
    try:
        if args.trimesh_rays <= 0:
            raise RuntimeError("--trimesh-rays 0")
        import trimesh

        mesh = trimesh.Trimesh(scene.vertices.astype(np.float64), scene.triangles, process=False)
        sub = rays[: args.trimesh_rays].astype(np.float64)
        native = trimesh.ray.ray_triangle.RayMeshIntersector(mesh)
        native.intersects_first(sub[:10, :3], sub[:10, 3:])  # builds its r-tree

        def native_first():
            return np.concatenate(
                [native.intersects_first(b[:, :3], b[:, 3:]) for b in np.array_split(sub, max(1, len(sub) // 10))]
            )

        def trimesh_native(t):
            # Over a subset: scaled to the full count, so that Mrays/s compare.
            wall, cpu = best(native_first, 1)
            return wall * n / len(sub), cpu * n / len(sub)

        contenders[f"trimesh {trimesh.__version__} ray_triangle (numpy; {len(sub)} rays, scaled)"] = (
            trimesh_native,
            [1],
        )
        ours = raytree.RayMeshIntersector(mesh, structure=args.structure)
        ours.intersects_first(sub[:10, :3], sub[:10, 3:])

        def trimesh_raytree(t):
            return best(lambda: ours.intersects_first(rays[:, :3], rays[:, 3:]), 1)

        contenders[f"trimesh API over raytree (RayMeshIntersector {args.structure}, all threads)"] = (
            trimesh_raytree,
            [os.cpu_count()],
        )
        native_ids = native_first()
        notes.append(
            f"trimesh ray_triangle agrees with raytree on {agreement(np.where(native_ids < 0, raytree.INVALID_ID, native_ids), reference[: len(sub)]):.2%} of its rays"
        )
    except Exception as e:
        notes.append(f"trimesh skipped: {e}")

    results = {}
    slow = {name for name in contenders if name.startswith("trimesh ") and "ray_triangle" in name}
    for t in threads:
        for r in range(args.repeats):
            # Round robin: a busy moment of the machine hurts every contender.
            for name, (fn, honoured) in contenders.items():
                if t not in honoured or (name in slow and r > 0):
                    continue
                wall, cpu = fn(t)
                old = results.get((name, t), (np.inf, np.inf))
                results[(name, t)] = (min(old[0], wall), min(old[1], cpu))

    if args.cli:
        with tempfile.TemporaryDirectory() as tmp:
            ray_file, hit_file = Path(tmp) / "rays.bin", Path(tmp) / "hits.bin"
            full = np.zeros((n, 8), np.float32)
            full[:, :6] = rays
            full[:, 7] = np.inf

            def cli_route(t):
                def once():
                    import resource

                    before = resource.getrusage(resource.RUSAGE_CHILDREN)
                    full.tofile(ray_file)
                    structure, _, traversal = args.structure.partition("/")
                    subprocess.run(
                        [args.cli, "trace", "-s", scene.name, "-a", structure,
                         "-t", traversal or "stack", "--sah-block", str(args.sah_block),
                         "--rays", str(ray_file), "-o", str(hit_file), "--threads", str(t)],
                        check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                    )
                    after = resource.getrusage(resource.RUSAGE_CHILDREN)
                    child_cpu[0] = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
                    return np.fromfile(hit_file, dtype=np.uint32).reshape(n, 4)[:, 1]

                child_cpu = [0.0]
                ids["raytree trace (ray file, new process)"] = once()
                wall, cpu = best(once, 1)
                return wall, cpu + child_cpu[0]

            for t in threads:
                results[("raytree trace (ray file, new process)", t)] = cli_route(t)

    print()
    print(
        "| contender | threads | seconds | Mrays/s | CPU seconds | Mrays per CPU second "
        "| time vs raytree cast_rays | same answers as raytree |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for (name, t), (wall, cpu) in results.items():
        base = results.get(("raytree cast_rays (Python)", t))
        ratio = f"{wall / base[0]:.2f}×" if base else "–"
        same = f"{agreement(ids[name], reference):.2%}" if name in ids else "–"
        print(
            f"| {name} | {t} | {wall:.3f} | {n / wall / 1e6:.2f} | {cpu:.3f} | {n / cpu / 1e6:.2f} "
            f"| {ratio} | {same} |"
        )
    for t in threads:
        (py, py_cpu) = results[("raytree cast_rays (Python)", t)]
        (rs, rs_cpu) = results[(RUST, t)]
        (tr, tr_cpu) = trace_alone[t]
        print(
            f"\nPython overhead on {t} thread(s): cast_rays {py:.3f} s ({py_cpu:.3f} CPU s) against "
            f"the Rust batch call (rays built from the arrays, then traced) {rs:.3f} s ({rs_cpu:.3f} CPU s): "
            f"{py / rs - 1:+.1%} ({py_cpu / rs_cpu - 1:+.1%} CPU); against its trace alone (rays built "
            f"beforehand, untimed) {tr:.3f} s ({tr_cpu:.3f} CPU s): {py / tr - 1:+.1%} ({py_cpu / tr_cpu - 1:+.1%} CPU)"
        )
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"\nload average {load:.2f} at the end")
    for note in notes:
        print(f"note: {note}")


if __name__ == "__main__":
    sys.exit(main())
