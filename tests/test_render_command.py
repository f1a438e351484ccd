"""``lookalike render``: pictures, contact sheet, seeds, and refusing to overwrite."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from lookalike.cli import main

CUBE_OBJ = """\
v -1 -1 -1
v 1 -1 -1
v 1 1 -1
v -1 1 -1
v -1 -1 1
v 1 -1 1
v 1 1 1
v -1 1 1
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
"""


@pytest.fixture
def cube(tmp_path):
    path = tmp_path / "cube.obj"
    path.write_text(CUBE_OBJ)
    return path


def render_args(cube, out, *extra):
    return ["render", str(cube), "-o", str(out), "--views", "3", "--resolution", "32", "--spp", "1", *extra]


def pictures(folder):
    return [np.asarray(Image.open(folder / f"view_{i:03d}.png")) for i in range(3)]


def test_writes_views_and_sheet(cube, tmp_path):
    out = tmp_path / "pictures"
    assert main(render_args(cube, out)) == 0
    views = pictures(out)
    for view in views:
        assert view.shape == (32, 32, 4)
        coverage = (view[..., 3] > 0).mean()
        assert 0.05 < coverage < 0.9  # the cube is in the picture, not filling it
        assert view[..., :3][view[..., 3] == 255].mean() > 10  # lit, not black
        assert (view[..., 3] == 0).any() and (view[0, :, 3] == 0).all()  # transparent background
    sheet = np.asarray(Image.open(out / "sheet.png"))
    assert sheet.shape == (64, 64, 3)  # 2 x 2 grid for 3 views


def test_seed_decides_the_views(cube, tmp_path):
    main(render_args(cube, tmp_path / "a", "--seed", "4"))
    main(render_args(cube, tmp_path / "b", "--seed", "4"))
    main(render_args(cube, tmp_path / "c", "--seed", "5"))
    a, b, c = pictures(tmp_path / "a"), pictures(tmp_path / "b"), pictures(tmp_path / "c")
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not all(np.array_equal(x, y) for x, y in zip(a, c))


def test_refuses_to_overwrite_without_force(cube, tmp_path, capsys):
    out = tmp_path / "pictures"
    assert main(render_args(cube, out)) == 0
    before = (out / "sheet.png").stat().st_mtime_ns
    assert main(render_args(cube, out)) == 2
    assert "--force" in capsys.readouterr().err
    assert (out / "sheet.png").stat().st_mtime_ns == before
    assert main(render_args(cube, out, "--force")) == 0


def test_bad_input_is_a_clear_error(tmp_path, capsys):
    assert main(["render", str(tmp_path / "missing.obj"), "-o", str(tmp_path / "out")]) == 2
    assert "missing.obj" in capsys.readouterr().err
    (tmp_path / "cube.obj").write_text(CUBE_OBJ)
    assert main(["render", str(tmp_path / "cube.obj"), "-o", str(tmp_path / "out"), "--views", "0"]) == 2
