"""What the commands print: plain-text tables of errors, comparisons and loop results.

Each function returns the text; :mod:`..cli` prints it (library code prints nothing).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pandas is not imported before the first frame (start-up time)
    import pandas as pd

    from ..loop.compare import Comparison


def format_table(rows: list[list[str]]) -> str:
    """Rows of cells as aligned columns, the first row a header underlined with dashes;
    the first column left-aligned, the others right-aligned."""
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in
                       enumerate(zip(r, widths, strict=True))) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def drive_errors_text(errors: pd.DataFrame) -> str:
    """The table of :func:`..loop.compare.errors_against_drive`: RMS and largest error
    of each quantity against the analytic model, in the quantity's unit."""
    rows = [["quantity", "frames", "RMS error", "max error", "RMS % of peak"]]
    for r in errors.itertuples():
        rows.append([f"{r.quantity} ({r.rows})", str(r.frames), f"{r.rms:.4g} {r.unit}",
                     f"{r.max_abs:.4g} {r.unit}", f"{r.rms_pct_of_peak:.2f}"])
    return format_table(rows)


def comparison_text(result: Comparison) -> str:
    """The summary table of a comparison (:func:`..loop.compare.compare`'s result)."""
    rows = [["quantity", "RMS error", "max error", "RMS % of peak", "fit %"]]
    for r in result.summary.itertuples():
        rows.append([r.quantity, f"{r.rms:.4g} {r.unit}", f"{r.max_abs:.4g} {r.unit}",
                     f"{r.rms_pct_of_peak:.2f}", f"{r.fit_pct:.2f}"])
    return format_table(rows)


def fit_text(report: dict) -> str:
    """The closed loop's result (``fit/report.json``) in a few lines: before and after,
    what was accepted, what looks alike, what was not tried and what is unexplained."""
    lines = [f"note: {m}" for m in report["messages"]]
    rows = [["", "θ RMSE (deg)", "max (deg)", "fit %", "residual white"]]
    for label, key in (("before (base model)", "before"), ("after", "after")):
        rows.append([label, f"{report[f'rmse_{key}_deg']:.4g}", f"{report[f'max_{key}_deg']:.4g}",
                     f"{report[f'fit_percent_{key}']:.3f}", str(report[f"residual_white_{key}"])])
    lines.append(format_table(rows))
    accepted = [c for c in report["candidates"] if c["accepted"]]
    fm = report.get("frame_motion") or {}
    if not accepted:
        lines.append("effects accepted on θ: none (no candidate explains the residual beyond "
                     "the noise)")
    if fm.get("accepted"):
        lines.append(f"effect accepted (A and C tracks): pivot_amp_mm: the frame shakes "
                     f"{fm['amp_mm']:.4g} ± {fm['amp_sigma_mm']:.2g} mm at {fm['hz']:.4g} ± "
                     f"{fm['hz_sigma']:.2g} Hz across A–C, {fm['amp_vector_mm']:.4g} mm as a "
                     f"whole (ΔBIC {fm['delta_bic']:.0f}); θ does not see it, v_B does")
    final = report["parameters"]
    for c in accepted:
        values = ", ".join(f"{k} = {final[k]['value']:.4g} ± {final[k]['sigma']:.2g}"
                           for k in c["parameters"])
        lines.append(f"effect accepted (round {c['round']}): {c['name']}: {values} "
                     f"(ΔBIC {c['delta_bic']:.0f} when added)")
    for name, d in report.get("effect_docs", {}).items():
        if d["also_looks_like"]:
            lines.append(f"  {name} is also what {d['also_looks_like']}")
    for g in report["look_alike_groups"]:
        lines.append(f"look-alikes: {', '.join(g['effects'])} fit equally well; to tell them "
                     f"apart, {g['separated_by']}")
    for n in report["not_separable"]:
        lines.append(f"not tried: {n['name']} needs --known {' or '.join(n['needs'])}")
    if report["unexplained"]:
        lines.append(f"unexplained: {report['unexplained']}")
        found = (report.get("leftover") or {}).get("discovery")
        if found:
            lines.append(f"proposed missing term: {found['equation']} (θ RMSE "
                         f"{found['rmse_before_deg']:.3g}° → {found['rmse_after_deg']:.3g}°)")
    return "\n".join(lines)


def reproducibility_text(table: pd.DataFrame, video: str, frames: int, patterns: int) -> str:
    """``cranktrack check``'s printout of a :func:`.tracker.reproducibility.reproducibility`
    table: a line of what was done, the table, and a sentence per marker of what to
    trust."""
    rows = [["marker", "found as is", "with the patterns", "moved median px", "95 % px",
             "σ median px", "moved more than σ", "jumps > 3 px"]]
    rows += [[r.marker, str(r.found), _span_of(r.found_min, r.found_max),
              f"{r.moved_median_px:.3f}",
              f"{r.moved_p95_px:.3f}", f"{r.sigma_median_px:.3f}",
              "-" if math.isnan(r.beyond_sigma) else f"{100 * r.beyond_sigma:.0f} %",
              f"{r.jumps} of {r.compared}"] for r in table.itertuples()]
    return "\n".join([f"{video}: {frames} frames tracked as is and with {patterns} invisible "
                      "±1 DN patterns", format_table(rows),
                      *(_what_to_trust(r) for r in table.itertuples())])


#: Frames found with the patterns within this fraction of those found as is are a few
#: borderline views, not another blob, size or colour taken once for the whole run.
BORDERLINE = 0.1


def _span_of(low: int, high: int) -> str:
    """``low–high``, or one number where they are the same."""
    return str(low) if low == high else f"{low}–{high}"


def _what_to_trust(r) -> str:
    """One sentence for a row of :func:`reproducibility_text`'s table."""
    if not r.found:
        return f"{r.marker}: not found as is; nothing to compare"
    said = []
    if r.found_min != r.found or r.found_max != r.found:
        counts = (f"found in {_span_of(r.found_min, r.found_max)} frames with the patterns "
                  f"against {r.found} as is")
        if max(abs(r.found_min - r.found), abs(r.found_max - r.found)) <= BORDERLINE * r.found:
            said.append(f"{counts}: a few borderline frames (a blurred or half-hidden view) "
                        "are found or missed on a pixel")
        else:
            said.append(f"{counts}: which blob, size or colour it takes hangs on a pixel")
    if r.jumps:
        said.append(f"{r.jumps} {'fix' if r.jumps == 1 else 'fixes'} moved more than 3 px: "
                    "another place or object")
    # Below a hundredth of a pixel either way is below anything a track is used for.
    if r.compared and r.moved_median_px > max(r.sigma_median_px, 0.01):
        said.append(f"its fixes move {r.moved_median_px:.2f} px (median) under a change no one "
                    f"could see, more than their σ ({r.sigma_median_px:.2f} px): trust its "
                    f"position to about {r.moved_p95_px:.2f} px, not to its σ")
    if not said:
        return (f"{r.marker}: the same frames, and fixes moved {r.moved_median_px:.3f} px "
                f"(median) against a σ of {r.sigma_median_px:.3f} px: steady")
    return f"{r.marker}: " + "; ".join(said)
