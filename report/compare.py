"""The comparison of a run with the spool model, as Markdown (``compare.md``)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd


def compare_markdown(fit: dict, summary: pd.DataFrame, figures: list[Path]) -> str:
    """``compare.md``: fitted and fixed parameters, each quantity's error, the figures.

    ``fit`` is :meth:`..loop.compare.SpoolFit.to_dict`; ``summary`` is
    :func:`..loop.compare.error_summary`'s table."""
    lines = ["# Measured vs spool model", "", "| parameter | value | 1σ | unit |",
             "|---|---|---|---|"]
    for k, v in fit["fitted"].items():
        lines.append(f"| {k} (fitted) | {v['value']:.5g} | {v['sigma']:.2g} | {v['unit']} |")
    for k, v in fit["fixed"].items():
        lines.append(f"| {k} (fixed) | {v['value']:.5g} | | {v['unit']} |")
    lines += ["", "| quantity | RMS error | max error | RMS % of peak | fit % | frames |",
              "|---|---|---|---|---|---|"]
    for r in summary.itertuples():
        lines.append(f"| {r.quantity} | {r.rms:.4g} {r.unit} | {r.max_abs:.4g} {r.unit} | "
                     f"{r.rms_pct_of_peak:.2f} | {r.fit_pct:.2f} | {r.frames} |")
    lines += [""] + [f"![{f.stem}]({f.name})" for f in figures] + [""]
    return "\n".join(lines)
