"""Run configuration: defaults, TOML round trip, validation, durations, and what it sets up:
learning rates, outline views, the loop's settings and the objective."""

from __future__ import annotations

import pytest

from lookalike.errors import ConfigError
from lookalike.fit.from_settings import loop_settings, objective
from lookalike.settings import (
    COLD_START,
    FIELD_FLIP_SHARE,
    FIELD_START,
    SPHERE_START,
    WARM_START,
    Config,
    learning_rates,
    outline_views,
    refresh_interval,
    validation_flip_share,
)
from lookalike.settings import (
    config_from_dict,
    load_config,
    parse_duration,
    to_toml,
    with_overrides,
)


def test_toml_round_trip_keeps_every_setting(tmp_path):
    config = config_from_dict({
        "io": {"input": "a.obj", "outdir": "out", "export_obj": True},
        "latent": {"triangles": 1500, "texture_size": 256, "init": "random"},
        "optim": {"iterations": 20, "laplacian_weight": 3.5, "loss": "smape", "time_budget": "2m"},
        "clamp": {"roughness": [0.1, 0.9]},
    })
    path = tmp_path / "run.toml"
    path.write_text(to_toml(config))
    again = load_config(path)
    assert again == config
    assert again.optim.time_budget == 120.0 and again.clamp.roughness == (0.1, 0.9)
    assert again.latent.ratio is None and again.latent.triangles == 1500


def test_defaults_round_trip():
    import tomllib
    assert config_from_dict(tomllib.loads(to_toml(Config()))) == Config()


@pytest.mark.parametrize("data, words", [
    ({"latent": {"triangles": 0}}, "positive"),
    ({"latent": {"triangles": -5}}, "positive"),
    ({"latent": {"triangles": 10, "ratio": 0.5}}, "not both"),
    ({"latent": {"ratio": 1.5}}, "(0, 1)"),
    ({"latent": {"triangles": "many"}}, "wrong type"),
    ({"optim": {"loss": "l3"}}, "optim.loss"),
    ({"optim": {"lr_textures": True}}, "wrong type"),
    ({"optim": {"time_budget": "soon"}}, "duration"),
    ({"optim": {"bogus": 1}}, "unknown key 'bogus'"),
    ({"extras": {}}, "unknown section [extras]"),
    ({"views": {"pool_size": 1, "batch_size": 4}}, "pool_size"),
    ({"optim": {"outline_views": -1}}, "optim.outline_views must not be negative"),
    ({"optim": {"lr_decades": -1.0}}, "optim.lr_decades must not be negative"),
    ({"optim": {"outline_weight": -0.5}}, "optim.outline_weight must not be negative"),
])
def test_invalid_settings_are_refused_with_a_clear_message(data, words):
    with pytest.raises(ConfigError, match=None) as info:
        config_from_dict(data)
    assert words in str(info.value)


def test_unreadable_files_are_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="no such configuration file"):
        load_config(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[optim\nseed = ")
    with pytest.raises(ConfigError, match="bad.toml: not a valid TOML"):
        load_config(bad)


@pytest.mark.parametrize("text, seconds", [
    ("90", 90.0), ("90s", 90.0), ("10m", 600.0), ("1h", 3600.0), ("1h30m", 5400.0), ("2.5m", 150.0), (45, 45.0),
])
def test_durations(text, seconds):
    assert parse_duration(text) == seconds


@pytest.mark.parametrize("text", ["", "m", "ten minutes", "0", "-5", "5d"])
def test_bad_durations(text):
    with pytest.raises(ConfigError):
        parse_duration(text)


def test_overrides_name_fields_and_a_count_replaces_a_ratio(tmp_path):
    path = tmp_path / "run.toml"
    path.write_text('[latent]\nratio = 0.1\n[optim]\nseed = 4\n')
    config = with_overrides(path, triangles=500, seed=None, time_budget="90s")
    assert config.latent.triangles == 500 and config.latent.ratio is None
    assert config.optim.seed == 4 and config.optim.time_budget == 90.0
    assert with_overrides(config, ratio=0.3).latent.triangles is None
    with pytest.raises(ConfigError, match=r"texture_size \(--texture-size\) must lie in \[4, 4096\]"):
        with_overrides(None, texture_size=2)


@pytest.mark.parametrize("init, expected", [
    ("bake", WARM_START[:2]), ("source", WARM_START[:2]), ("average", COLD_START[:2]), ("random", COLD_START[:2]),
])
def test_warm_starts_get_lower_learning_rates_unless_they_are_set(init, expected):
    assert learning_rates(config_from_dict({"latent": {"init": init}})) == expected
    assert WARM_START.lr_positions < COLD_START.lr_positions and WARM_START.lr_textures < COLD_START.lr_textures
    given = config_from_dict({"latent": {"init": init}, "optim": {"lr_positions": 0.001}})
    assert learning_rates(given) == (0.001, expected[1])
    given = config_from_dict({"latent": {"init": init}, "optim": {"lr_textures": 0.02}})
    assert learning_rates(given) == (expected[0], 0.02)


@pytest.mark.parametrize("init, optim, expected", [("bake", {}, 2), ("source", {}, 2), ("random", {}, 0),
                                                   ("average", {}, 0), ("random", {"outline_views": 3}, 3),
                                                   ("bake", {"outline_views": 0}, 0)])
def test_warm_starts_add_outline_views_unless_set(init, optim, expected):
    assert outline_views(config_from_dict({"latent": {"init": init}, "optim": optim})) == expected


@pytest.mark.parametrize("pool, outline, expected", [(0, True, 3), (16, True, 3), (4, True, 2), (16, False, 0)])
def test_outline_views_fit_the_pool_and_skip_latents_with_alpha(pool, outline, expected):
    """``outline``: the latent's coverage is geometry's alone (no trained alpha)."""
    cfg = config_from_dict({"optim": {"outline_views": 3}, "views": {"batch_size": 2, "pool_size": pool}})
    assert loop_settings(cfg, outline=outline).views_per_step == 2 + expected


@pytest.mark.parametrize("init", ["bake", "random"])
def test_the_loop_settings_follow_the_configuration(init):
    cfg = config_from_dict({"latent": {"init": init}, "views": {"batch_size": 3},
                            "optim": {"iterations": 40, "lr_decay": 0.01, "seed": 9, "validate_every": 7,
                                      "rollback_lr_factor": 0.25, "max_rollbacks": 5, "outline_views": 0}})
    settings = loop_settings(cfg, outline=True)
    lr_positions, lr_textures = learning_rates(cfg)
    assert settings.learning_rates == {"positions": lr_positions, "textures": lr_textures, "emissive": lr_textures,
                                       "displacement": lr_textures, "weights": 0.1}
    heights = config_from_dict({"optim": {"lr_displacement": 0.001}})
    assert loop_settings(heights, outline=True).learning_rates["displacement"] == 0.001
    emissive = config_from_dict({"optim": {"lr_emissive": 0.002}})
    assert loop_settings(emissive, outline=True).learning_rates["emissive"] == 0.002
    assert (settings.views_per_step, settings.iterations, settings.lr_decay, settings.seed) == (3, 40, 0.01, 9)
    assert settings.lr_decades == (WARM_START if init == "bake" else COLD_START).lr_decades
    assert loop_settings(config_from_dict({"optim": {"lr_decades": 3.0}}), outline=True).lr_decades == 3.0
    assert (settings.validate_every, settings.rollback_lr_factor, settings.max_rollbacks) == (7, 0.25, 5)


def test_the_objective_follows_the_configuration():
    from lookalike.fit.losses import smape

    cfg = config_from_dict({"views": {"batch_size": 3},
                            "optim": {"loss": "smape", "outline_weight": 0.5, "laplacian_weight": 2.0,
                                      "laplacian_min_fraction": 0.1, "laplacian_decay_fraction": 0.4}})
    made = objective(cfg)
    assert made.loss_fn is smape and made.batch_size == 3 and made.outline_weight == 0.5
    assert (made.regularizer_weight, made.min_fraction, made.decay_fraction) == (2.0, 0.1, 0.4)
    assert objective(Config()).regularizer_weight is None  # the heuristic


@pytest.mark.parametrize("input, expected", [("rook.py", FIELD_START), ("gear.GLSL", FIELD_START),
                                             ("bunny.glb", WARM_START), ("", WARM_START)])
def test_an_implicit_surfaces_bake_steps_its_texels_more_finely(input, expected):
    """A field's start samples its own material at the surface: its texels need small corrections."""
    cfg = config_from_dict({"io": {"input": input}, "latent": {"init": "bake"}})
    assert learning_rates(cfg) == (expected.lr_positions, expected.lr_textures)
    assert FIELD_START.lr_textures < WARM_START.lr_textures
    assert learning_rates(config_from_dict({"io": {"input": input}, "latent": {"init": "sphere"}}))[1] == \
        SPHERE_START.lr_textures


@pytest.mark.parametrize("input, expected", [("rook.py", FIELD_FLIP_SHARE), ("gear.GLSL", FIELD_FLIP_SHARE),
                                             ("bunny.glb", 0.0), ("", 0.0)])
def test_flip_weighs_in_the_validation_of_an_implicit_surface_only_unless_set(input, expected):
    assert validation_flip_share(config_from_dict({"io": {"input": input}})) == expected
    assert validation_flip_share(config_from_dict({"io": {"input": input}, "optim": {"validation_flip_share": 0.25}})) \
        == 0.25
    with pytest.raises(ConfigError, match="validation_flip_share"):
        config_from_dict({"optim": {"validation_flip_share": 1.5}})


def test_a_users_mesh_starts_warm():
    """A user's mesh is fitted onto the surface first, and its textures are a bake or its own."""
    cfg = config_from_dict({"io": {"init_mesh": "lod.glb", "input": "x.glb"}, "latent": {"init": "random"}})
    assert learning_rates(cfg) == (WARM_START.lr_positions, WARM_START.lr_textures)
    assert loop_settings(cfg, outline=True).views_per_step == 1 + WARM_START.outline_views


def test_large_inputs_refresh_the_view_pool_proportionally_less_often():
    cfg = config_from_dict({"views": {"refresh_every": 2, "refresh_triangles": 250_000}})
    assert [refresh_interval(cfg, t) for t in (5_000, 250_000, 260_000, 1_000_000, 4_000_000)] == [2, 2, 3, 8, 32]
    assert refresh_interval(config_from_dict({"views": {"refresh_every": 0}}), 4_000_000) == 0
    # a peeled reference costs its layers: 16 of them (render.layers > 1) count as 16 inputs
    peeled = config_from_dict({"views": {"refresh_every": 2, "refresh_triangles": 250_000}, "render": {"layers": 8}})
    assert [refresh_interval(peeled, t) for t in (5_000, 192_000)] == [2, 25]
    with pytest.raises(ConfigError, match="refresh_triangles"):
        config_from_dict({"views": {"refresh_triangles": 0}})


def test_the_reference_peels_as_deep_as_the_judge_sees_where_models_peel():
    """Foliage is deeper than the models' layers: the reference peels ``MAX_LAYERS`` (Cycles'
    transparent bounces in the judge) wherever models peel more than one, and one layer where
    they peel one; the input reference of a run is built with it."""
    import torch

    from lookalike.asset import Asset, Mesh
    from lookalike.fit.reference import MeshReference
    from lookalike.jobs.reference_kinds import run_reference
    from lookalike.limits import MAX_LAYERS
    from lookalike.settings import RenderConfig

    assert RenderConfig(layers=1).reference_layers == 1
    assert RenderConfig(layers=8).reference_layers == MAX_LAYERS == 16
    cfg = Config(render=RenderConfig(layers=8))
    reference = run_reference(Asset(mesh=Mesh(v_pos=torch.rand(3, 3), t_pos_idx=torch.tensor([[0, 1, 2]]))), cfg,
                              False).renderer
    assert isinstance(reference, MeshReference) and reference.layers == MAX_LAYERS
