"""A reference must show the input: each held-out and validation view's coverage against the
input's own rasterized coverage, checked before any fitting (``jobs.reference_coverage``)."""

from __future__ import annotations

import dataclasses

import pytest
import torch
from io_factory import box

from lookalike.asset import Asset, Material, Texture
from lookalike.cli import main
from lookalike.errors import ReferenceCoverageError
from lookalike.fit.reference import MeshReference
from lookalike.jobs import simplify as simplify_module
from lookalike.jobs.reference_coverage import MIN_COVERAGE_SHARE, coverage_shares
from lookalike.jobs.reference_kinds import RunReference
from lookalike.jobs.simplify import SIMPLIFY
from lookalike.settings import config_from_dict

TINY = {"latent": {"texture_size": 32}, "render": {"resolution": 32},
        "views": {"pool_size": 4, "heldout": 4, "validation": 2}}


def test_a_view_s_share_is_its_coverage_over_the_input_s_and_absent_inputs_have_none():
    reference = torch.zeros(3, 8, 8)
    reference[0, :4] = 1.0       # half of what the input covers
    reference[1] = 1.0           # all of it
    reference[2, 0, 0] = 1.0     # the input is absent from view 2
    input = torch.ones(3, 8, 8)
    input[2] = 0.0
    shares = coverage_shares(reference, input)
    assert shares[:2].tolist() == [0.5, 1.0] and torch.isnan(shares[2])


class LookingAway(MeshReference):
    """The input drawn from behind each camera, looking away from it: nothing in view."""

    def render(self, camera, light, resolution, spp, pose=None):
        turned = dataclasses.replace(camera, mv=torch.diag(torch.tensor([-1.0, 1.0, -1.0, 1.0])) @ camera.mv)
        return super().render(turned, light, resolution, spp, pose)


class TopShown(MeshReference):
    """The input with all but the top quarter of every view blanked out."""

    def render(self, camera, light, resolution, spp, pose=None):
        pictures = super().render(camera, light, resolution, spp, pose)
        pictures[:, resolution // 4:] = 0.0
        return pictures


def painted_box() -> Asset:
    return Asset(mesh=box(4), materials=[Material(kd=Texture.constant([0.6, 0.4, 0.2, 1.0]))])


@pytest.mark.parametrize("renderer", [LookingAway, TopShown])
def test_a_reference_that_does_not_show_the_input_stops_the_run_with_one_line(tmp_path, capsys, monkeypatch, renderer):
    """A reference that shows nothing (a camera looking away) or much less than the input's
    silhouette (its top) ends the run before any fitting: one line, exit status 2, and
    the output folder left as it was found."""
    class Elsewhere(RunReference):
        draws_input = False

    app = dataclasses.replace(SIMPLIFY, reference=lambda asset, cfg, moving: Elsewhere(renderer(asset)))
    monkeypatch.setattr(simplify_module, "SIMPLIFY", app)
    with pytest.raises(ReferenceCoverageError, match="of the input's silhouette"):
        simplify_module.simplify(painted_box(), tmp_path / "api", triangles=40, iterations=5, progress=False,
                                 config=config_from_dict(TINY))
    assert not (tmp_path / "api").exists()
    source = tmp_path / "box.glb"
    from lookalike import io
    io.save(painted_box(), source)
    (tmp_path / "config.toml").write_text('[latent]\ntexture_size = 32\n[render]\nresolution = 32\n'
                                          '[views]\npool_size = 4\nheldout = 4\nvalidation = 2\n')
    code = main(["simplify", str(source), "-o", str(tmp_path / "out"), "--triangles", "40", "--iterations", "5",
                 "--config", str(tmp_path / "config.toml"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "silhouette" in err[0]
    assert not (tmp_path / "out").exists()


def test_the_input_drawn_by_our_pipeline_is_its_own_coverage(tmp_path):
    """The usual reference passes the check with every share exactly 1 (the report says nothing
    of it), and the share bound lies well below what a sound reference shows."""
    result = simplify_module.simplify(painted_box(), tmp_path / "out", triangles=40, iterations=3, progress=False,
                                      config=config_from_dict(TINY))
    coverage = result.metrics["reference_coverage"]
    assert coverage["min"] == coverage["max"] == 1.0 and coverage["views"] == 6
    assert MIN_COVERAGE_SHARE <= 0.5
    assert "silhouette in its" not in result.report.read_text()
