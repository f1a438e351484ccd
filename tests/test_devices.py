"""Where a run's tensors live: moving nested views and assets, resolving the device setting, and
a reference drawing for a run on another device."""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest
import torch

from lookalike.devices import moved, resolve_device
from lookalike.errors import DeviceError
from lookalike.fit.reference import ReferenceOn, reference_on

META = torch.device("meta")  # a device other than the CPU that every torch has


@dataclass
class Inner:
    a: torch.Tensor
    name: str = "inner"


@dataclass(frozen=True)
class Outer:
    inner: Inner
    items: list
    table: dict
    cached: torch.Tensor = field(init=False, default=None)


def test_moved_moves_every_tensor_of_nested_dataclasses_lists_and_dicts_and_copies_only_what_moved():
    outer = Outer(Inner(torch.ones(2)), [torch.zeros(1), (torch.zeros(3), 4)], {"t": torch.ones(1), "n": None})
    object.__setattr__(outer, "cached", torch.ones(5))
    there = moved(outer, META)
    assert there.inner.a.device == META and there.cached.device == META
    assert there.items[0].device == META and there.items[1][0].device == META and there.items[1][1] == 4
    assert there.table["t"].device == META and there.table["n"] is None and there.inner.name == "inner"
    assert isinstance(there.items[1], tuple) and outer.inner.a.device.type == "cpu"  # the original stays
    assert moved(outer, torch.device("cpu")) is outer  # nothing to move: the same object


def test_the_device_setting_resolves_to_the_cpu_without_a_gpu_and_cuda_names_why():
    assert resolve_device("cpu") == torch.device("cpu")
    if torch.cuda.is_available():
        pytest.skip("this machine has a GPU")
    assert resolve_device("auto") == torch.device("cpu")
    with pytest.raises(DeviceError, match="torch"):
        resolve_device("cuda")


class _Recording:
    """A reference that records where its views came from (``movable``: it has ``to``)."""

    fixed_light = None

    def __init__(self, device=torch.device("cpu")):
        self.device, self.seen = device, []

    def render(self, camera, light, resolution, spp, pose=None):
        self.seen.append((camera.device, light.device))
        return torch.zeros(camera.shape[0], resolution, resolution, 4, device=self.device)

    def bounding_sphere(self):
        return torch.zeros(3), 1.0


class _Movable(_Recording):
    def to(self, device):
        return _Movable(device)


def test_a_movable_reference_renders_on_the_run_device_and_any_other_where_it_is():
    camera, light = torch.zeros(2, 4, 4), torch.zeros(2, 3)
    movable = ReferenceOn(_Movable(), META)
    assert movable.render(camera, light, 8, 1).device == META
    assert movable.wrapped.seen == [(META, META)] and movable.wrapped.device == META
    fixed = ReferenceOn(_Recording(), META)
    images = fixed.render(camera, light, 8, 1)
    assert images.device == META and images.shape == (2, 8, 8, 4)
    assert fixed.wrapped.seen == [(torch.device("cpu"), torch.device("cpu"))] and fixed.fixed_light is None
    cpu = _Recording()
    assert reference_on(cpu, torch.device("cpu")) is cpu


def test_held_out_views_draw_every_model_on_their_device_and_keep_the_pictures_on_the_cpu():
    from lookalike.asset import Asset
    from lookalike.fit.training_views import view_sampler
    from lookalike.report.heldout import HeldoutViews
    from mesh_factory import icosphere

    class Picture:
        fixed_light = None

        def render(self, camera, light, resolution, spp, pose=None):
            return torch.full((camera.batch_size, resolution, resolution, 4), 0.5)

    seen = []

    def draw(asset, camera, light, pose=None):
        seen.append((asset.mesh.v_pos.device, camera.mv.device, light.position.device))
        return torch.zeros(camera.batch_size, 8, 8, 4)  # a real draw's pictures come back from META

    views = HeldoutViews(Picture(), view_sampler(torch.zeros(3), 1.0), 5, 0, 8, 1, device=META)
    assert views.reference.device.type == "cpu" and views.coverage.device.type == "cpu"
    model = Asset(icosphere(1))
    assert views.renders(model, draw).shape == (5, 8, 8, 4)
    assert seen == [(META, META, META)] * 2 and model.mesh.v_pos.device.type == "cpu"  # two chunks; the model stays


def test_a_run_goes_to_the_gpu_only_where_its_kind_has_run_on_one():
    from types import SimpleNamespace

    from lookalike.jobs.run import run_device

    simplify, cards = SimpleNamespace(runs_on_gpu=True, command="simplify"), SimpleNamespace(runs_on_gpu=False, command="cards")
    drawn, traced = SimpleNamespace(draws_input=True), SimpleNamespace(draws_input=False)
    for app, moving, reference, says in ((cards, False, drawn, "lookalike cards runs on the CPU only"),
                                         (simplify, True, drawn, "an animated input runs on the CPU only"),
                                         (simplify, False, traced, "a field, a path tracer")):
        assert run_device(app, "auto", moving, reference) == torch.device("cpu")
        with pytest.raises(DeviceError, match=says):
            run_device(app, "cuda", moving, reference)
    assert run_device(simplify, "cpu", False, drawn) == torch.device("cpu")
    if not torch.cuda.is_available():
        with pytest.raises(DeviceError, match="torch"):  # a kind that may: the GPU's own answer
            run_device(simplify, "cuda", False, drawn)
