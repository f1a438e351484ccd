"""Every default that a subcommand's ``--help`` states is the value its run uses: the settings'
defaults are read from the application (``lookalike.jobs.run.run_settings``, what a run starts
from), the other options' from the parser's own defaults, which the command passes on."""

from __future__ import annotations

import re

import pytest

from lookalike.cli import build_parser
from lookalike.commands import command_modules
from lookalike.settings import Config, parse_duration, setting_value

SETTING_OF_OPTION = {"ratio": "ratio", "texture_size": "texture_size", "resolution": "resolution",
                     "time_budget": "time_budget", "init": "init", "seed": "seed", "alpha": "alpha_mode",
                     "levels": "tessellation_levels", "shading": "displacement_shading", "reference": "renderer",
                     "lighting": "lighting", "spp": "spp"}
"""Options (by ``dest``) that set a setting, and its name."""


def application_of(command: str):
    """The application whose settings the command's run uses, or ``None``."""
    if command in ("simplify", "batch"):
        from lookalike.jobs.simplify import SIMPLIFY
        return SIMPLIFY
    if command == "cards":
        from lookalike.jobs.cards import CARDS
        return CARDS
    if command == "displace":
        from lookalike.jobs.displace import DISPLACE
        return DISPLACE
    return None


def stated_defaults(command: str) -> dict[str, str]:
    """``{dest: stated default}`` of every option of ``lookalike COMMAND --help`` that states
    one as a value ("(default 0.02)"; "(default: ...)" describes and is not checked)."""
    parser = build_parser([command])
    sub = next(a for a in parser._actions if a.dest == "command").choices[command]
    stated = {}
    for action in sub._actions:
        match = re.search(r"\(default ([^:,)](?:[^,)]|,(?=\S))*)[,)]", action.help or "")  # "0,1,2" is one value
        if match:
            stated[action.dest] = (match.group(1), action.default)
    return stated


def same(stated: str, actual, dest: str) -> bool:
    if dest == "time_budget":
        return parse_duration(stated.replace(" ", "")) == parse_duration(actual)
    if isinstance(actual, tuple):
        return stated == ",".join(map(str, actual))
    return stated == str(actual)


@pytest.mark.parametrize("command", sorted(command_modules()))
def test_every_stated_default_is_the_one_a_run_uses(command):
    from lookalike.jobs.run import run_settings

    stated = stated_defaults(command)
    app = application_of(command)
    for dest, (text, parser_default) in stated.items():
        if parser_default is not None:
            assert same(text, parser_default, dest), f"{command} --{dest}: says {text}, passes {parser_default}"
            continue
        assert dest in SETTING_OF_OPTION, f"{command} --{dest} states a default ({text}) that nothing checks"
        settings = run_settings(app) if app is not None else Config()
        actual = setting_value(settings, SETTING_OF_OPTION[dest])
        assert same(text, actual, dest), f"{command} --{dest}: says {text}, a run uses {actual}"


def test_the_cards_ratio_is_stated_as_its_run_uses_it():
    """The defect this guards against: ``cards --help`` once stated simplify's ratio."""
    from lookalike.jobs.cards import CARDS
    from lookalike.jobs.run import run_settings

    assert stated_defaults("cards")["ratio"][0] == str(run_settings(CARDS).latent.ratio) != \
        stated_defaults("simplify")["ratio"][0]
