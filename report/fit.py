"""``RUN/fit/``: the closed loop's report — before and after, every candidate, the plots."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from ..files import ensure_dir, write_csv_atomic, write_json_atomic, write_text_atomic
from ..loop.candidates import CAMERA_CANDIDATES
from ..loop.evidence import BIC_THRESHOLD, IMPRINT_SIGMAS
from ..loop.result import LoopResult
from ..loop.simulate import MODELS
from ..run_folder import FIT_FIGURE, FIT_REPORT, FIT_REPORT_JSON, FIT_TABLE


def fit_table(result: LoopResult, t_s: np.ndarray) -> pd.DataFrame:
    """Measured θ, the base and final models and both residuals, deg, per fitted frame."""
    base, final = result.base, result.final
    measured = np.degrees(base.model + base.residual)
    return pd.DataFrame({
        "t_s": t_s, "theta_deg_measured": measured,
        "theta_deg_base": np.degrees(base.model), "theta_deg_final": np.degrees(final.model),
        "residual_before_deg": np.degrees(base.residual),
        "residual_after_deg": np.degrees(final.residual)})


def plot_residuals(table: pd.DataFrame, result: LoopResult, path: Path) -> Path:
    """Save :func:`residual_figure` as a PNG at ``path``."""
    path = Path(path)
    residual_figure(table, result).savefig(path, dpi=110)
    return path


def residual_figure(table: pd.DataFrame, result: LoopResult) -> Figure:
    """θ (deg) with both models, and the residual before and after the accepted effects,
    over t (s); ``table`` is :func:`fit_table`'s. A bare matplotlib Figure: it leaves the
    plotting backend alone, and a notebook shows it as it is."""
    fig = Figure(figsize=(7.5, 7.5))
    axes = fig.subplots(3, 1, sharex=True)
    t = table["t_s"]
    ax = axes[0]
    ax.plot(t, table["theta_deg_measured"], ".", ms=3, color="tab:blue", label="measured")
    ax.plot(t, table["theta_deg_base"], "-", lw=1, color="tab:red", label="base model")
    if result.final.effects:
        ax.plot(t, table["theta_deg_final"], "--", lw=1, color="tab:green",
                label="with " + ", ".join(result.final.effects))
    ax.set_ylabel("θ (deg)")
    ax.legend(fontsize=8)
    sigma = result.noise.sigma_deg
    for ax, col, title in ((axes[1], "residual_before_deg", "before"),
                           (axes[2], "residual_after_deg", "after")):
        ax.axhspan(-sigma, sigma, color="0.85", lw=0, label="±1σ noise")
        ax.plot(t, table[col], ".-", ms=3, lw=0.6, color="tab:purple")
        rms = float(np.sqrt(np.mean(table[col] ** 2)))
        ax.set_ylabel(f"residual {title} (deg)")
        ax.set_title(f"residual {title}: RMS {rms:.4g}°", fontsize=9)
    axes[1].legend(fontsize=8, loc="upper right")
    axes[-1].set_xlabel("t (s)")
    fig.tight_layout()
    return fig


#: What to look at on the rig when the loop names an effect.
RIG_CHECKS = {
    "slack_mm": "check that the wire is taut before the drive starts",
    "time_offset_s": "check when the drive really starts against the video's clock (film an "
                     "LED lit with the drive)",
    "clock_scale": "check the frame rate the camera recorded against the one the file claims",
    "spool_growth_per_s": "wind the wire in a single layer or on a larger spool",
    "return_spring_hz": "the crank rings on the wire and spring: damp it or lighten it",
    "wire_stretch_mm": "use a stiffer wire or a weaker return spring",
    "coulomb_rad_s2": "free the pivot: clean or replace its bearing, or ease what presses "
                      "on it",
    "play_deg": "tighten the joint between the wire and the crank (a loose pin or loop "
                "at B)",
    "lens_edge_pct": "calibrate the camera (`cranktrack calibrate camera`, then `calibrate "
                     "plane`)",
    "tilt_vertical_deg": "square the camera to the rig's plane, or calibrate the plane",
    "tilt_horizontal_deg": "square the camera to the rig's plane, or calibrate the plane",
    "readout_s": "the camera's rolling shutter: measure the run again with the readout "
                 "found (`cranktrack measure RUN --rolling-shutter-ms MS`; measure it apart "
                 "with `cranktrack calibrate readout` on two markers on a ruler shaken "
                 "sideways), or use a global shutter",
    "pivot_amp_mm": "fix the bench or the pivot's mount",
}


def _rig_check(name: str, fitted: dict) -> str:
    """What to look at on the rig for the effect ``name``, with the value the loop fitted
    (``fitted["value"]``) where the remedy is to type it: a readout in s becomes the
    ms that `--rolling-shutter-ms` takes (only a top-to-bottom one, > 0)."""
    check = RIG_CHECKS[name]
    value = fitted.get("value")
    if name == "readout_s" and value is not None and value > 0:
        check = check.replace("--rolling-shutter-ms MS", f"--rolling-shutter-ms {value * 1e3:.2f}")
    return check


def _camera_caveat(report: dict) -> str:
    """A sentence when the rigid crank says the camera bends the angles and no camera
    effect was named: the base model's free values may have taken that bias in."""
    links = report.get("links") or {}
    crank = links.get("L2_mm") or {}
    if not report.get("camera_effect_suspected") or any(
            n in CAMERA_CANDIDATES for n in report["effects"]):
        return ""
    return (f" But the rigid crank |AB| varies by {crank.get('std_mm', float('nan')):.3g} mm "
            f"(the tracker allows {links.get('crank_std_expected_mm', float('nan')):.3g}) "
            f"and follows θ (r = {crank.get('r_with_theta', float('nan')):.2f}): the camera is "
            "probably tilted or its lens distorts. The model's own parameters can take such "
            "a bias in without leaving a residual, so its fitted values carry it: calibrate "
            "the camera (`cranktrack calibrate camera`, then `calibrate plane`) and track "
            "again before trusting them.")


def plain_summary(report: dict) -> str:
    """One paragraph for a lab user: what was found, how sure, what it changes in the
    numbers and what to check on the rig."""
    before, after = report["rmse_before_deg"], report["rmse_after_deg"]
    noise = report["tracker_sigma_deg"] or report["noise"]["sigma_deg"]
    params = report["parameters"]
    if report["unexplained"]:
        out = (f"The {report['model']} model misses the measured angle by {before:.3g}° RMS, "
               f"well above the tracker's noise ({noise:.3g}°), and no effect in the library "
               "accounts for it, so none is named. What is left: "
               f"{report['leftover']['sentence']}" if report.get("leftover") else
               f"The {report['model']} model misses the measured angle by {before:.3g}° RMS "
               f"and no effect accounts for it.")
        found = (report.get("leftover") or {}).get("discovery")
        if found:
            out += (f". A sparse regression over functions of θ, ω, time and the drive "
                    f"proposes `{found['equation']}`, which would bring the error from "
                    f"{found['rmse_before_deg']:.3g}° to {found['rmse_after_deg']:.3g}° RMS: a "
                    "shape to look for on the rig, not a named effect")
        return out + (". Treat the model's numbers as approximate until that is found; the "
                      "statistics below say what was tried.")
    if not report["effects"]:
        return (f"The {report['model']} model alone reproduces the measured angle to "
                f"{before:.3g}° RMS, at the tracker's noise ({noise:.3g}°): nothing is "
                "missing that this video's angles can show." + _camera_caveat(report))
    found = []
    for name in report["effects"]:
        p = params.get(name, {})
        unit = "" if p.get("unit") in ("", "1", None) else f" {p['unit']}"
        value = (f" = {p['value']:.3g} ± {1.96 * p['sigma']:.2g}{unit} (95 %)"
                 if "sigma" in p else "")
        found.append(f"`{name}`{value}")
    checks = [_rig_check(n, params.get(n, {})) for n in report["effects"] if n in RIG_CHECKS]
    return (f"Found: {', '.join(found)}. With it the model misses the measured angle by "
            f"{after:.3g}° RMS instead of {before:.3g}° (worst frame "
            f"{report['max_after_deg']:.3g}° instead of {report['max_before_deg']:.3g}°), "
            f"against the tracker's noise of {noise:.3g}°; each effect had to win by a wide "
            "margin and keep its value on its own to be named."
            + (f" On the rig: {'; '.join(checks)}." if checks else "") + _camera_caveat(report))


def _links_section(report: dict) -> list[str]:
    """Markdown lines on how rigid the links measured (none without L2)."""
    lines: list[str] = []
    links = report.get("links", {})
    if "L2_mm" in links:
        lines += ["", "## Rigid links (a camera effect bends them, a mechanism effect does not)",
                  "", "| link | median (mm) | σ (mm) | r with θ |", "|---|---|---|---|"]
        for name in ("L1_mm", "L2_mm"):
            if name in links:
                v = links[name]
                lines.append(f"| {name} | {v['median_mm']:.3f} | {v['std_mm']:.4f} | "
                             f"{v['r_with_theta']:+.2f} |")
        lines.append("")
        lines.append(f"Camera effect suspected: {report['camera_effect_suspected']} (the "
                     f"tracker's σ allows {links['crank_std_expected_mm']:.4f} mm on |AB|).")
    return lines


def _frame_motion_section(report: dict) -> list[str]:
    """Markdown lines on whether the frame shook (none when it was not looked at)."""
    lines: list[str] = []
    fm = report.get("frame_motion")
    if fm:
        lines += ["", "## Is the frame still? (A and C across the A–C line; θ cannot show this)",
                  ""]
        if fm["accepted"]:
            lines.append(f"The frame shakes: {fm['amp_mm']:.4g} ± {fm['amp_sigma_mm']:.2g} mm "
                         f"across the A–C line ({fm['amp_along_mm']:.4g} mm along it, "
                         f"{fm['amp_vector_mm']:.4g} mm as a whole) "
                         f"at {fm['hz']:.4g} ± {fm['hz_sigma']:.2g} Hz (ΔBIC "
                         f"{fm['delta_bic']:.1f}); A and C move {fm['rmse_before_mm']:.4g} mm "
                         f"RMS across the line, {fm['rmse_after_mm']:.4g} mm once the shake is "
                         "taken out. θ and ω do not see it; the velocity of B carries the "
                         "frame's own velocity. Fix the bench or the pivot's mount.")
        else:
            lines.append(f"Still, as far as the tracks tell: {fm['reason'] or 'no shake'} "
                         f"(A and C move {fm['rmse_before_mm']:.4g} mm RMS across the line; "
                         f"the tracker's σ there is {fm['tracker_sigma_mm']:.4g} mm).")
    return lines


def _discovery_section(found: dict | None) -> list[str]:
    """The proposed equation for the missing term, its terms and its error before/after."""
    if not found:
        return ["", "**Proposed missing term:** none; no function of θ, ω, time or the drive "
                "in the sparse regression's library takes a clear share of what is left."]
    lines = ["", f"**Proposed missing term** ({found['method']}):", "",
             f"    {found['equation']}", "",
             f"θ RMSE {found['rmse_before_deg']:.4g}° → {found['rmse_after_deg']:.4g}° with it "
             f"(base model refitted to first order; ΔBIC {found['delta_bic']:.0f}).", "",
             "| term | coefficient |", "|---|---|"]
    lines += [f"| {k} | {v:.4g} |" for k, v in found["terms"].items()]
    return lines


def report_markdown(report: dict) -> str:
    """The report as Markdown: a plain paragraph, then before/after, accepted effects and
    every candidate."""
    lines = [f"# Closing the loop: {report['model']} model", "", "## In short", "",
             plain_summary(report), "", "## The statistics", ""]
    effects = report["effects"]
    lines.append("Accepted effects, in order: " + (", ".join(f"`{e}`" for e in effects)
                                                   if effects else "none") + ".")
    lines += ["", "| | RMSE (deg) | max (deg) | fit % | residual white |", "|---|---|---|---|---|",
              f"| before (base model) | {report['rmse_before_deg']:.4g} | "
              f"{report['max_before_deg']:.4g} | {report['fit_percent_before']:.3f} | "
              f"{report['residual_white_before']} |",
              f"| after | {report['rmse_after_deg']:.4g} | {report['max_after_deg']:.4g} | "
              f"{report['fit_percent_after']:.3f} | {report['residual_white_after']} |", ""]
    n = report["noise"]
    lines.append(f"Noise the fits are judged against: σ = {n['sigma_deg']:.4g}° per frame, "
                 f"{n['effective_frames']:.1f} independent frames of {n['frames']} "
                 f"({n['source']}); the tracker's own σ is "
                 f"{report['tracker_sigma_deg']:.4g}°.")
    lines += ["", "## Parameters", "", "| parameter | value | 1σ | 95 % interval | |",
              "|---|---|---|---|---|"]
    for k, v in report["parameters"].items():
        unit = "" if v["unit"] == "1" else f" {v['unit']}"
        if v["fixed"]:
            lines.append(f"| {k} | {v['value']:.6g}{unit} | | | known |")
        else:
            lo, hi = v["ci95"]
            lines.append(f"| {k} | {v['value']:.6g}{unit} | {v['sigma']:.3g} | "
                         f"[{lo:.5g}, {hi:.5g}] | fitted |")
    lines += ["", "## Candidates", "",
              f"Accepted only with ΔBIC > {BIC_THRESHOLD:g}, a 95 % interval that excludes "
              f"no effect, a plausible value and an imprint on θ above {IMPRINT_SIGMAS:g}σ of "
              "the noise.", "",
              "| round | effect | ΔBIC | RMSE after (deg) | imprint (deg) | value | accepted | "
              "note |", "|---|---|---|---|---|---|---|---|"]
    for c in report["candidates"]:
        vals = ", ".join(f"{k} = {p['value']:.4g} ± {p['sigma']:.2g}"
                         for k, p in c["parameters"].items())
        lines.append(f"| {c['round']} | {c['name']} | {c['delta_bic']:.1f} | "
                     f"{c['rmse_deg']:.4g} | {c['imprint_deg']:.3g} | {vals} | "
                     f"{'yes' if c['accepted'] else 'no'} | {c['note']} |")
    docs = report.get("effect_docs", {})
    if any(d["also_looks_like"] for d in docs.values()):
        lines += ["", "## What else an accepted effect looks like", ""]
        for name, d in docs.items():
            if d["also_looks_like"]:
                lines.append(f"- `{name}` is also what {d['also_looks_like']}.")
    if report["look_alike_groups"]:
        lines += ["", "## Effects that look alike", ""]
        for g in report["look_alike_groups"]:
            lines.append(f"- {', '.join(g['effects'])} explain the residual equally well; "
                         f"to tell them apart: {g['separated_by']}.")
    if report["not_separable"]:
        lines += ["", "## Not tried: not separable with what is known", ""]
        for s in report["not_separable"]:
            lines.append(f"- `{s['name']}` needs {' or '.join(s['needs'])} (`--known`): "
                         f"{s['why']}.")
    lines += ["", "## What the residual correlates with", "", "| | before | after |",
              "|---|---|---|"]
    before, after = report["diagnosis_before"], report["diagnosis_after"]
    for k in before["correlations"]:
        a = after["correlations"].get(k)
        lines.append(f"| {k} | {before['correlations'][k]:+.2f} | "
                     f"{'' if a is None else f'{a:+.2f}'} |")
    phases = {"before": "before the crank moves", "moving": "while it moves",
              "after": "after it stops"}
    for name, label in phases.items():
        b, a = before["phases"].get(name), after["phases"].get(name)
        if b and a:
            lines.append(f"| RMSE {label} (deg) | {b['rmse_deg']:.4g} | {a['rmse_deg']:.4g} |")
    lines += _links_section(report) + _frame_motion_section(report)
    if report["unexplained"]:
        lines += ["", f"**Unexplained:** {report['unexplained']}."]
        lines += _discovery_section((report.get("leftover") or {}).get("discovery"))
    for m in report["messages"]:
        lines += ["", f"Note: {m}."]
    lines += ["", "![residuals](residuals.png)", ""]
    return "\n".join(lines)


def fit_report(result: LoopResult) -> dict:
    """``report.json``'s content: the loop's result and what each accepted effect looks like."""
    report = result.to_dict()
    library = {**MODELS[result.model].candidates, **CAMERA_CANDIDATES}
    report["effect_docs"] = {name: {"shows_as": library[name].shows_as,
                                    "also_looks_like": library[name].also_looks_like}
                             for name in result.effects if name in library}
    if result.shake_accepted:
        report["effect_docs"]["pivot_amp_mm"] = {
            "shows_as": "A and C moving together across the A–C line, periodically",
            "also_looks_like": ""}
    return report


def write_fit_report(folder: Path, result: LoopResult, t_s: np.ndarray) -> list[Path]:
    """Write ``report.json``, ``report.md``, ``fit.csv`` and ``residuals.png`` in ``folder``."""
    folder = ensure_dir(Path(folder))
    report = fit_report(result)
    table = fit_table(result, t_s)
    return [write_json_atomic(folder / FIT_REPORT_JSON, report),
            write_csv_atomic(folder / FIT_TABLE, table),
            plot_residuals(table, result, folder / FIT_FIGURE),
            write_text_atomic(folder / FIT_REPORT, report_markdown(report))]
