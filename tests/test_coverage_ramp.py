"""The alpha test trained in (``latent.alpha_mode = "mask"``): a ramp of coverage around the
cutoff, as wide as blending at first, narrowed to glTF's hard test over the run."""

from __future__ import annotations

import dataclasses

import pytest
import torch

from lookalike.asset import Asset, Material, Texture
from lookalike.fit.textured_mesh import TexturedMesh
from lookalike.jobs.alpha_export import AlphaChoice, annealed_alpha, training_start, written_alpha
from lookalike.jobs.written_model import WrittenModel
from lookalike.settings import ClampConfig
from lookalike.shading import Camera, PointLight, render
from test_pipeline import NO_SPECULAR, quad


def coverage_of(alpha: float, mode: str, ramp: float = 0.0) -> float:
    """The coverage our pipeline draws for a facing quad of constant ``alpha``."""
    material = Material(kd=Texture.constant([0.0, 0.0, 0.0, alpha]), ks=Texture.constant(NO_SPECULAR),
                        alpha_mode=mode, alpha_cutoff=0.5, coverage_ramp=ramp, double_sided=True)
    eye = torch.tensor([[0.0, 0.0, 3.0]])
    image = render(Asset(quad(size=4.0), [material]), Camera.looking_at(eye, torch.zeros(1, 3)),
                   PointLight(position=eye, intensity=torch.ones(1, 3)), 8)
    return float(image[0, 4, 4, 3])


@pytest.mark.parametrize("alpha", [0.0, 0.3, 0.55, 0.9, 1.0])
def test_a_full_ramp_draws_alpha_as_blending_does_and_no_ramp_is_the_hard_test(alpha):
    assert coverage_of(alpha, "MASK", ramp=1.0) == pytest.approx(coverage_of(alpha, "BLEND"), abs=1e-6)
    assert coverage_of(alpha, "MASK", ramp=0.0) == pytest.approx(1.0 if alpha >= 0.5 else 0.0, abs=1e-6)
    assert coverage_of(alpha, "MASK", ramp=0.2) == pytest.approx(min(max((alpha - 0.5) / 0.2 + 0.5, 0.0), 1.0), abs=1e-6)


def ramped_latent(mask_anneal: float) -> TexturedMesh:
    material = Material(kd=Texture(torch.full((4, 4, 4), 0.6)), ks=Texture.constant([0.0, 0.5, 0.0]),
                        alpha_mode="MASK", coverage_ramp=1.0, double_sided=True)
    mesh = dataclasses.replace(quad(), uv=quad().uv[:1])
    return TexturedMesh.from_asset(Asset(mesh, [material]), centre=torch.zeros(3), radius=1.0, limits=ClampConfig(),
                                   msaa=1, train_alpha=True, mask_anneal=mask_anneal)


def test_the_ramp_narrows_over_its_share_of_the_run_and_is_never_written():
    latent = ramped_latent(0.5)
    widths = []
    for fraction in (None, 0.0, 0.25, 0.5, 0.9):
        latent.at_progress(fraction)
        widths.append(latent.as_asset().materials[0].coverage_ramp)
    assert widths == [1.0, 1.0, 0.5, 0.0, 0.0]
    latent.at_progress(0.25)
    assert latent.export().materials[0].coverage_ramp == 0.0          # as glTF draws it
    resumed = ramped_latent(0.5)
    resumed.load_state_dict(latent.state_dict())
    assert resumed.coverage_ramp == 0.5 and resumed.mask_anneal == 0.5
    still = ramped_latent(0.0)
    still.at_progress(0.9)
    assert still.as_asset().materials[0].coverage_ramp == 1.0         # no schedule: the start's ramp stays


def test_mask_runs_train_the_ramp_and_are_validated_as_written_at_their_own_cutoff_and_the_starts():
    asset = Asset(quad(), [Material(kd=Texture(torch.rand(4, 4, 4)), alpha_mode="BLEND", double_sided=True)])
    start = training_start(asset, "mask", 0.75)
    assert annealed_alpha(start) and not annealed_alpha(training_start(asset, "mask", 0.0))
    written = written_alpha(start, "mask", AlphaChoice(cutoff=0.3))
    assert [(m.alpha_mode, m.alpha_cutoff, m.coverage_ramp) for m in written.materials] == [("MASK", 0.3, 0.0)]
    seen = []

    class Views:  # PSNR alone (FLIP's share 0)
        def validation_score(self, model, draw, flip_share):
            seen.append(model.materials[0].alpha_cutoff)
            return {0.5: 20.0, 0.3: 25.0}[model.materials[0].alpha_cutoff]

    class Latent:
        def export(self):
            return start

    # annealed: the better of its own cutoff and the start's choice (thin parts vanish at 0.5)
    for annealed, cutoffs in ((True, {0.5, 0.3}), (False, {0.3})):
        seen.clear()
        model = WrittenModel("mask", Views(), draw=None, annealed=annealed)
        model.choice = AlphaChoice(cutoff=0.3)                     # the start's choice
        assert model.validate(Latent()) == 25.0 and set(seen) == cutoffs
