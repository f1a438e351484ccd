"""``lookalike bench cards``: its cases run ``cards`` as they say."""

from __future__ import annotations

import pytest

import lookalike.jobs.cards as cards_job
from lookalike.bench import cards as bench_cards


class Ran(Exception):
    """Raised by the stand-in ``cards`` once it has seen its keywords."""


@pytest.mark.parametrize("name, alpha", [("grass-tuft-2pct", None), ("grass-tuft-2pct-blend", "blend")])
def test_a_case_runs_cards_with_its_alpha(tmp_path, monkeypatch, name, alpha):
    seen = {}

    def stand_in(source, outdir, **keywords):
        seen.update(keywords)
        raise Ran

    monkeypatch.setattr(cards_job, "cards", stand_in)
    case = next(c for c in bench_cards.ASSETS if c.name == name)
    with pytest.raises(Ran):
        bench_cards.run(out=tmp_path, assets=(case,), time_budget=1.0)
    assert seen.get("alpha_mode") == alpha and seen["triangles"] == 480
