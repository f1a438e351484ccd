"""Reports: PSNR and FLIP on held-out views (``metrics``, ``heldout``), pictures (``images``),
the loss curve (``plot``), the run's record (``record``), and the HTML page (``html``) built
from it."""

from .html import write_report
from .metrics import flip, psnr
from .record import MethodResult, RunRecord, score_method

__all__ = ["MethodResult", "RunRecord", "flip", "psnr", "score_method", "write_report"]
