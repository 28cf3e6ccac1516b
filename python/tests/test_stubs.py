"""The type stubs (raytree/_raytree.pyi) match the extension: names,
signatures and defaults, checked by mypy's stubtest."""

import subprocess
import sys

import pytest


def test_stubs_match_the_extension():
    pytest.importorskip("mypy")
    run = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "raytree._raytree"],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stdout + run.stderr
