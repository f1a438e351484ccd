"""The reference of a run and what each kind of it brings to the run (``jobs.run``).

A reference draws the input by the input's own renderer (``lookalike.fit.reference``). Beside
its pictures, each kind of input brings what only it knows: the start the latent is given, how
the baselines are drawn and which ones it adds, what is written after the fit, and what the
report says of it. ``run_reference`` picks the kind; the run itself has no branch on it.

- ``RunReference``: a mesh drawn by our pipeline (posed per view where it moves): its views
  are the input as our rasterizer draws it.
- ``FieldInput``: an implicit surface, sphere traced in a sphere around its mesh; the field's
  bake onto the fitted mesh is offered as an alternative to the fitted maps.
- ``PathTracedInput``: an asset path traced under fixed lighting (``jobs.path_traced``).
"""

from __future__ import annotations

from dataclasses import replace

import torch

from ..asset import Asset
from ..asset.field_planes import PlaneHold, plane_hold, plane_slots
from ..asset.pose import Poses
from ..errors import ConfigError
from ..fit.from_settings import shadow_mapping
from ..fit.reference import FieldReference, MeshReference, PathTracedReference, Reference, SkinnedReference
from ..init.initial_guess import InitialGuess, baked_onto
from ..io.normal_frames import on_crease_normals
from ..report.heldout import AssetRenderer
from ..report.record import RunRecord
from ..settings import Config
from ..shading.camera import Camera
from ..shading.light import PointLight
from .path_traced import CACHE_FOLDER, lit_as_fitted, path_traced_reference, with_baked_lighting, with_emission

FIELD_MARGIN = 1.0 / 64
"""An implicit surface's bounding sphere reaches this share of its bounds beyond its mesh's
(which marching cubes places within a cube of the surface)."""

REBAKED = "ours with the field baked again onto it"
"""The label of a field's classic bake onto the fitted mesh (``FieldInput.alternatives``)."""

WITHOUT_NORMAL_MAP = "ours on the field's creases and planes, without its normal map"
"""The label of a field's fitted model written without its normal maps (``FieldInput.alternatives``)."""

TRACED_FIELD_TRIANGLES = 2_000_000
"""Triangles whose rasterization costs about what sphere tracing a view of a Python field does
(``docs/benchmarks.md``): with the default ``views.refresh_triangles`` its pool is refreshed
every 16 steps instead of every 2, where refreshing took over half of every step."""


class RunReference:
    """A reference as a run uses it: ``renderer`` draws the views (``lookalike.fit.reference``);
    the methods say what the kind adds to the run. This base class is
    the input drawn by our own pipeline, so its views are the input's own rasterization
    (``draws_input``) and it adds nothing.

    Attributes:
        label: what the report calls its pictures.
        draws_input: its coverage is, by construction, the input's as our rasterizer draws it.
    """

    label = "Reference"
    draws_input = True

    def __init__(self, renderer: Reference):
        self.renderer = renderer

    def latent_start(self, start: Asset) -> Asset:
        """The model the latent starts as (and the start the written model is compared with),
        given the run's ``start``."""
        return start

    def drawn_triangles(self, asset: Asset) -> int:
        """How many triangles drawing one view of the reference costs as much as, which sets how
        often the training views' pool is refreshed (``settings.refresh_interval``): the input's."""
        return asset.mesh.num_triangles

    def baseline_draw(self, draw: AssetRenderer) -> tuple[AssetRenderer, str]:
        """How the baselines are drawn, given how ours is (``draw``), and the words added to
        their labels."""
        return draw, ""

    def extra_baselines(self, asset: Asset, start: Asset) -> list[tuple[str, str, Asset]]:
        """``(key, label, model)`` scored beside the baselines every run has, given the input
        ``asset`` and the ``latent_start``."""
        return []

    def plane_hold(self, start: Asset) -> PlaneHold | None:
        """The vertices of ``start`` the fit holds on planes of the input
        (``fit.textured_mesh.TexturedMesh.hold_on_planes``), or ``None``: none here."""
        return None

    def written(self, model: Asset) -> Asset:
        """What is written of the fitted ``model``."""
        return model

    def alternatives(self, model: Asset) -> dict[str, Asset]:
        """Models the run may write instead of the fitted ``model``, by the label the report
        gives them, each before ``written`` (the run writes each, and the fit, before the
        validation views choose: ``jobs.run.optimise``). None here."""
        return {}

    def alternatives_seconds(self, guess: InitialGuess) -> float:
        """Seconds ``alternatives`` is expected to take, left out of the loop's share."""
        return 0.0

    def annotate(self, record: RunRecord, pool_bytes: int) -> None:
        """Add what the report says of this reference to ``record`` (its coverage already
        there; the training views' pool holds ``pool_bytes``)."""
        coverage = record.reference_coverage
        if not self.draws_input and coverage:
            record.notes.append(f"{self.label.lower()} covers {coverage['min']:.1%} to {coverage['max']:.1%} of the "
                                f"input's rasterized silhouette in its {coverage['views']} held-out and validation views")


class FieldInput(RunReference):
    """An implicit surface sphere-traced (``FieldReference``): its outline is the field's, not
    its marching-cubes mesh's. The fit holds the start's faces that lie on the field's planes on
    them (``plane_hold``). Its model is written on normals split at its creases and where the
    field's planes meet, the normal map re-expressed onto them
    (``io.normal_frames.on_crease_normals``): a fit that started on smooth normals
    (``jobs.simplify``) shades as fitted, in a rasterizer and in Cycles alike."""

    draws_input = False

    def __init__(self, renderer: FieldReference, asset: Asset, texture_size: int):
        super().__init__(renderer)
        self.asset, self.texture_size = asset, texture_size
        self.held: PlaneHold | None = None

    def drawn_triangles(self, asset: Asset) -> int:
        """A Python field is sphere traced in torch, on the CPU, at the cost of rasterizing
        ``TRACED_FIELD_TRIANGLES``; a GLSL field in OpenGL, about as fast as its marching-cubes
        mesh draws."""
        return TRACED_FIELD_TRIANGLES if asset.field.kind == "python" else asset.mesh.num_triangles

    def plane_hold(self, start: Asset) -> PlaneHold | None:
        """Every vertex of a face that lies on a plane of the field, on that plane
        (``asset.field_planes``): a face the fit tilts off its plane, its normal map turning the
        shading back, is lit otherwise by a renderer that tests the light against the facets."""
        self.held = plane_hold(self.asset.field, start.mesh.v_pos, start.mesh.t_pos_idx)
        return self.held

    def written(self, model: Asset) -> Asset:
        """On crease normals, parted also where the field's planes meet (``plane_slots``)."""
        return on_crease_normals(model, apart=plane_slots(self.asset.field, model.mesh.v_pos, model.mesh.t_pos_idx))

    def alternatives(self, model: Asset) -> dict[str, Asset]:
        """The model without its normal maps (``WITHOUT_NORMAL_MAP``): where the
        field is planes and smooth blends, normals split at its creases and planes shade it as
        the field does, and the map's grain only adds error, in every renderer. And the field's
        classic bake onto the fitted mesh (``init.initial_guess.baked_onto``): a
        vertex's step turns its shading frame, and the fitted normal map, made under the old
        frame, turns with it, so that perceptual error rises inside the surface where the
        outline gains; the bake keeps the fitted geometry and makes the maps for its frames.
        No bake for a model the bake cannot make: displaced, or with fitted mips."""
        offered = {}
        if any(m.normal is not None for m in model.materials):
            offered[WITHOUT_NORMAL_MAP] = replace(model, materials=[replace(m, normal=None) for m in model.materials])
        if model.mesh.uv and not any(m.displacement is not None or m.kd.mips is not None for m in model.materials):
            offered[REBAKED] = baked_onto(self.asset, model.mesh, self.texture_size)[0]
        return offered

    def alternatives_seconds(self, guess: InitialGuess) -> float:
        """About the start's bake's time."""
        return 0.0 if guess.bake is None else guess.bake.seconds

    def annotate(self, record: RunRecord, pool_bytes: int) -> None:
        super().annotate(record, pool_bytes)
        if self.held is not None and self.held.faces:
            record.notes.append(f"{self.held.faces} faces of the start lie on planes of the field: their "
                                f"{self.held.index.numel()} corners were held on those planes through the fit "
                                "(on their line or point where planes meet), so that they stay as flat as the field")


class PathTracedInput(RunReference):
    """An asset path traced under fixed lighting (``PathTracedReference``). The latent learns
    the light our rasterizer does not compute into an emission map; the model is written lit
    by the lighting's analytic part, or unlit. Where that analytic part lights nothing (an
    environment map, or ``--unlit``), the emission is the whole appearance: it starts as the
    classic bake of the lighting (``with_baked_lighting``), which is scored as a baseline of its
    own, and our rasterizer would draw the other baselines black: they are path traced under the
    same lighting instead, as an offline renderer shows them."""

    label = "Reference (path traced)"
    draws_input = False

    def __init__(self, renderer: PathTracedReference, cfg: Config):
        super().__init__(renderer)
        self.cfg = cfg
        self.lit = bool(renderer.fixed_light.intensity.abs().max() > 0)
        self._traced: tuple[Asset, PathTracedReference] | None = None

    def latent_start(self, start: Asset) -> Asset:
        return with_emission(start) if self.lit else with_baked_lighting(start, self.renderer)

    def draw_traced(self, model: Asset, camera: Camera, light: PointLight, pose: Poses | None = None) -> torch.Tensor:
        """``model`` path traced as the reference is (no cache: a baseline is drawn once)."""
        if self._traced is None or self._traced[0] is not model:
            reference = self.renderer
            self._traced = (model, PathTracedReference(model, reference.lighting, reference.spp,
                                                           reference.max_depth, None, reference.seed))
        return self._traced[1].render(camera, light, self.cfg.render.resolution, self.cfg.render.target_spp)

    def baseline_draw(self, draw: AssetRenderer) -> tuple[AssetRenderer, str]:
        return (draw, "") if self.lit else (self.draw_traced, " (path traced)")

    def extra_baselines(self, asset: Asset, start: Asset) -> list[tuple[str, str, Asset]]:
        if self.lit:
            return [("input_rasterized", "Input, rasterized", asset)]
        return [("lighting_baked", "Classic bake of the lighting", self.written(start))]

    def written(self, model: Asset) -> Asset:
        return lit_as_fitted(model, self.renderer.fixed_light, self.cfg.reference.unlit)

    def annotate(self, record: RunRecord, pool_bytes: int) -> None:
        super().annotate(record, pool_bytes)
        cost = {**self.renderer.summary(), "pool_bytes": pool_bytes}
        record.reference_views, record.reference_label = cost, self.label
        record.notes.append(
            f"reference: path traced by Mitsuba 3 ({cost['variant']}), {cost['lighting']} lighting, {cost['spp']} "
            f"samples per pixel, paths of up to {cost['max_depth']} vertices: {cost['views_rendered']} views rendered "
            f"in {cost['seconds']:.0f} s, {cost['views_from_cache']} read from {CACHE_FOLDER}/")
        if not self.lit:
            record.notes.append(
                "the baselines are path traced under the reference's lighting: it has no part a rasterizer computes "
                f"({'--unlit' if self.cfg.reference.unlit else 'an environment map'}), so ours, drawn unlit, is "
                "compared with what an offline renderer shows of them (the input rasterized is not scored); ours "
                "starts from the classic bake of the lighting (the light leaving the input path traced at each "
                "texel, averaged over the directions it is seen from), scored beside them as it is drawn")


def run_reference(asset: Asset, cfg: Config, moving: bool) -> RunReference:
    """The input drawn by its own renderer: path traced under fixed lighting where
    ``reference.renderer`` says so; an implicit surface sphere-traced (in a sphere around its
    mesh, ``FIELD_MARGIN`` of its bounds wider); a mesh by our pipeline, posed per view where
    ``moving``, else still, with ``render.reference_layers`` depth-peeled layers, shadowing itself
    where ``render.shadows`` says so. Raises ``ConfigError`` for shadows on an implicit surface,
    whose sphere tracing casts none."""
    if cfg.reference.path_traced:
        return PathTracedInput(path_traced_reference(asset, cfg, moving), cfg)
    if asset.field is not None:
        if cfg.render.shadows:
            raise ConfigError("render.shadows: an implicit surface's sphere-traced reference casts no shadows")
        centre, radius = asset.mesh.bounding_sphere()
        extent = float((asset.field.hi - asset.field.lo).max())
        return FieldInput(FieldReference(asset.field, (centre, radius + FIELD_MARGIN * extent)), asset,
                          cfg.latent.texture_size)
    shadows = shadow_mapping(cfg)
    return RunReference(SkinnedReference(asset, shadows) if moving
                        else MeshReference(asset, cfg.render.reference_layers, shadows))

