"""Reports: PSNR and FLIP on held-out views (``metrics``), pictures (``images``), the loss
curve (``plot``), and the HTML page (``html``) built from a ``ReportData`` (``data``)."""

from .data import MethodResult, ReportData, score_method
from .html import write_report
from .metrics import flip, psnr, tonemap

__all__ = ["MethodResult", "ReportData", "flip", "psnr", "score_method", "tonemap", "write_report"]
