"""What a run of any application returns (``lookalike.jobs.run.run``), and its terminal summary."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..asset import Asset
from ..phases import SEPARATOR


@dataclass
class RunResult:
    """What a run wrote.

    Attributes:
        outdir: the output folder.
        model: path of ``model.glb``.
        report: path of ``report.html``.
        metrics: the content of ``metrics.json``.
        interrupted: the run was stopped by Ctrl-C or SIGTERM (the files hold the best result
            so far and ``checkpoint.pt`` lets ``resume=True`` continue).
        baselines: the models ours was compared with, in memory and not written:
            ``{"decimated" (or "init_mesh"): Asset, "baked": Asset, "start": Asset}`` (each where
            the run had it) and the initial guess's comparisons by key (``InitialGuess``); e.g.
            for judging them in another renderer.
        command: the ``lookalike`` subcommand that ran it.
    """

    outdir: Path
    model: Path
    report: Path
    metrics: dict
    interrupted: bool = False
    baselines: dict[str, Asset] = field(default_factory=dict)
    command: str = "simplify"

    def summary(self) -> str:
        """A few lines for the terminal: where to look, and how much we gained."""
        m = self.metrics
        heldout = m["heldout"]
        base, ours = heldout[m["methods"][0]], heldout["ours"]
        lines = [
            f"{'interrupted; best result so far' if self.interrupted else 'done'}: "
            f"{m['triangles']['output']:,} triangles (input {m['triangles']['input']:,}), "
            f"{m['iterations']} iterations in {m['seconds']['total']:.0f} s",
            f"held-out PSNR: {_lower(base['label'])} {base['psnr']:.2f} dB, ours {ours['psnr']:.2f} dB "
            f"({ours['psnr'] - base['psnr']:+.2f} dB); FLIP {base['flip']:.4f} -> {ours['flip']:.4f}",
        ]
        for key in (k for k in m["methods"][1:] if k != "ours"):
            other = heldout[key]
            lines.append(f"{_lower(other['label'])}: PSNR {other['psnr']:.2f} dB "
                         f"(ours {ours['psnr'] - other['psnr']:+.2f} dB), FLIP {other['flip']:.4f}")
        if "profile" in m:
            lines += _profile_lines(m["profile"])
        lines += [f"model:  {self.model}", f"report: {self.report}"]
        if self.interrupted:
            lines.append(f"continue with: lookalike {self.command} {m['input']} -o {self.outdir} --resume")
        return "\n".join(lines)


def _lower(label: str) -> str:
    return label[0].lower() + label[1:]


def _profile_lines(profile: dict) -> list[str]:
    """The profile's phases, nested phases indented: name, wall seconds, CPU per wall."""
    lines = ["where the time went (wall s, CPU/wall; nested phases indented):"]
    for path, t in profile.items():
        depth = path.count(SEPARATOR)
        lines.append(f"  {'  ' * depth}{path.split(SEPARATOR)[-1]:<{40 - 2 * depth}} "
                     f"{t['wall_s']:8.1f}  {t['cpu_per_wall']:4.2f}")
    return lines
