"""``report.md``: the run at a glance, for a person who never opens Rerun."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from ..files import write_text_atomic
from ..run_folder import (
    COMPARE_FIT,
    COMPARE_TABLE,
    FIT_DIR,
    FIT_REPORT_JSON,
    KINEMATICS,
    KINEMATICS_FIGURE,
    MOTION,
    REPORT,
    RUN_INFO,
    TRACKS,
    TRACKS_FIGURE,
    RunFolder,
)
from ..tracker.scatter import at_rest, found_xy

PANELS = (("theta_deg", "θ (deg)"), ("omega_rad_s", "ω (rad/s)"), ("vB_mm_s", "|v_B| (mm/s)"))


def plot_kinematics(kinematics: pd.DataFrame, comparison: pd.DataFrame | None,
                    path: str | os.PathLike) -> Path:
    """θ, ω and |v_B| over time with ±1σ bands, and the model if there is one."""
    fig = Figure(figsize=(7.0, 7.2))
    axes = fig.subplots(len(PANELS), 1, sharex=True)
    t = kinematics["t_s"]
    for ax, (col, label) in zip(axes, PANELS, strict=True):
        m, s = kinematics[col], kinematics[f"{col}_sigma"]
        ax.fill_between(t, m - s, m + s, color="tab:blue", alpha=0.25, lw=0, label="±1σ")
        ax.plot(t, m, ".", ms=3, color="tab:blue", label="measured")
        if comparison is not None:
            ax.plot(comparison["t_s"], comparison[f"{col}_model"], "-", color="tab:red",
                    lw=1.2, label="model")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    axes[-1].set_xlabel("t (s)")
    fig.suptitle("Measured kinematics")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    return out


def plot_tracks(tracks: pd.DataFrame, size: tuple[int, int] | None,
                path: str | os.PathLike) -> Path:
    """Each marker's found positions: x and y (px) over time, and its path in the
    frame (y down, as in the picture; ``size`` is the frame's width and height)."""
    fig = Figure(figsize=(9.0, 5.2))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.3, 1.0))
    ax_x, ax_y = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0])
    ax_path = fig.add_subplot(grid[:, 1])
    t = tracks["t_s"].to_numpy(float)
    for m in [c[:-3] for c in tracks.columns if c.endswith("_ok")]:
        xy = found_xy(tracks, m)
        (line,) = ax_x.plot(t, xy[:, 0], ".-", ms=3, lw=0.6, label=m)
        ax_y.plot(t, xy[:, 1], ".-", ms=3, lw=0.6, color=line.get_color())
        ax_path.plot(xy[:, 0], xy[:, 1], ".-", ms=3, lw=0.6, color=line.get_color())
    ax_x.set_ylabel("x (px)")
    ax_y.set_ylabel("y (px, down)")
    ax_y.set_xlabel("t (s)")
    for ax in (ax_x, ax_y, ax_path):
        ax.grid(alpha=0.3)
    ax_x.legend(loc="best", fontsize=8)
    if size:
        ax_path.set_xlim(0, size[0])
        ax_path.set_ylim(size[1], 0)
    else:
        ax_path.invert_yaxis()
    ax_path.set_aspect("equal")
    ax_path.set_xlabel("x (px)")
    ax_path.set_title("in the frame (gaps where not found)", fontsize=9)
    fig.suptitle("Tracks, in pixels (the run has no kinematics)")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=100)
    return out


def _rest_checks(tracks: pd.DataFrame) -> list[str]:
    """Lines on each marker that stood still (the pivot A): its scatter about where it
    stood against the σ the tracker gave, a check of σ on the run's own footage. It
    sees the random part of the error only: on the demo render the pivot's error
    against truth is mostly a steady 0.010 / 0.026 px (x / y) with 0.003–0.006 px of
    scatter, and σ (0.026 px) covers both."""
    lines = []
    for m in [c[:-3] for c in tracks.columns if c.endswith("_ok")]:
        check = at_rest(found_xy(tracks, m), tracks[f"{m}_sigma_px"].to_numpy(float))
        if check is not None:
            lines.append(
                f"- {m} stood still ({check.frames} frames): it scatters by "
                f"{check.scatter_px:.4f} px per axis about where it stands, its median σ is "
                f"{check.sigma_px:.4f} px, and ±1σ holds it in {100 * check.coverage:.0f} % of "
                "coordinates. The scatter is the random part of its error; a steady offset "
                "(the codec's, the fit's) does not show in it, and σ covers that too, so more "
                "than 68 % is usual. Much less means σ is too narrow, or the marker or the "
                "camera moved.")
    return ["", *lines] if lines else []


def _motion_lines(run: Path, tracks: pd.DataFrame) -> list[str]:
    """The report's lines on motion.csv: per marker, the medians of its velocity and
    acceleration over the frames that have them (a thrown body's ``ay`` is −g there)."""
    if not (run / MOTION).exists():
        return []
    motion = pd.read_csv(run / MOTION)
    lines = ["", "## Motion", "",
             "Each marker's velocity (mm/s) and acceleration (mm/s²) per frame are in "
             f"[{MOTION}]({MOTION}), with σ; the plane's y is up. Medians over the frames "
             "that have them (median σ):", "",
             "| marker | frames | vx | vy | ax | ay |", "|---|---|---|---|---|---|"]
    for m in [c[:-3] for c in tracks.columns if c.endswith("_ok")]:
        if f"{m}_ax_mm_s2" not in motion:
            continue
        cells = []
        for col in ("vx_mm_s", "vy_mm_s", "ax_mm_s2", "ay_mm_s2"):
            v, sig = motion[f"{m}_{col}"], motion[f"{m}_{col}_sigma"]
            cells.append(f"{np.nanmedian(v):.5g} ({np.nanmedian(sig):.2g})"
                         if v.notna().any() else "–")
        lines.append(f"| {m} | {int(motion[f'{m}_ay_mm_s2'].notna().sum())} | "
                     + " | ".join(cells) + " |")
    return lines


def _swing_taken(swing: dict, done: str) -> str:
    """The sentence on the effects ``fit --model pendulum`` took, from ``swing.json``."""
    final = swing["candidates"][done]
    g = swing.get("g_mm_s2", {}).get(done)
    return (f"Accepted, one at a time: {done}; then period {final['period_s']:.5f} ± "
            f"{final['period_sigma_s']:.5f} s"
            + (f", g = {g[0] / 1e3:.4f} ± {g[1] / 1e3:.4f} m/s²" if g else "")
            + f", residual {final['rms']:.3g} {swing['unit']} RMS.")


#: What a loop's section says where it took no effect (``loop.evidence.BIC_THRESHOLD``,
#: not imported: that module loads statsmodels, which a report has no other use for).
NOTHING_TAKEN = "No effect lowers the BIC by more than 20."


def _loop_section(heading: str, summary: str, taken: str | None, details: str) -> list[str]:
    """A report section for one of ``fit``'s loops (flight, pendulum, rotation): its
    heading, the base model's line ``summary`` followed by what it ``taken`` (None:
    nothing), and the link to its ``details`` file."""
    return ["", heading, "", summary + (NOTHING_TAKEN if taken is None else taken),
            f"Details in [{details}]({details})."]


def write_report(run: str | os.PathLike) -> Path:
    """Write ``run/report.md`` (and ``kinematics.png``, or ``tracks.png`` in a run without
    kinematics) from what the run folder holds."""
    run = Path(run)
    folder = RunFolder(run)
    info = folder.read_json(RUN_INFO) or {}
    tracks = pd.read_csv(run / TRACKS)
    kin = pd.read_csv(run / KINEMATICS) if (run / KINEMATICS).exists() else None
    comparison = pd.read_csv(run / COMPARE_TABLE) if (run / COMPARE_TABLE).exists() else None
    compare = folder.read_json(COMPARE_FIT)
    src = info.get("source", {})
    lines = [f"# Run report: {Path(src.get('path', '?')).name}", ""]
    lines += [f"- source: `{src.get('path', '?')}` ({src.get('codec', '?')}, "
              f"{src.get('width', '?')}×{src.get('height', '?')})",
              f"- cranktrack {info.get('cranktrack', '?')}, {info.get('created', '')}"]
    libraries = {k: v for k, v in info.get("libraries", {}).items() if k != "cranktrack"}
    if libraries:
        # Another build of these can take another blob first (environment.py).
        lines += ["- with " + ", ".join(f"{k} {v}" for k, v in libraries.items())]
    lines += [""]
    timing = info.get("tracking", {}).get("timing", {})
    lines += ["## Tracking", "",
              f"{len(tracks)} frames, median rate {timing.get('median_fps') or float('nan'):.3f} "
              f"fps, variable rate: {timing.get('variable_rate')}, gaps in the timestamps: "
              f"{timing.get('gaps')} (≈ {timing.get('dropped_frames_estimate')} dropped frames), "
              f"duplicated timestamps: {timing.get('duplicated_timestamps')}.", "",
              "| marker | found | median σ (px) | statuses |", "|---|---|---|---|"]
    for m in [c[:-3] for c in tracks.columns if c.endswith("_ok")]:
        statuses = (tracks[f"{m}_status"].value_counts().to_dict()
                    if f"{m}_status" in tracks else {})
        st = ", ".join(f"{k} {v}" for k, v in statuses.items())
        sig = tracks[f"{m}_sigma_px"].to_numpy(float)
        med = f"{np.median(sig[np.isfinite(sig)]):.4f}" if np.isfinite(sig).any() else "–"
        lines.append(f"| {m} | {100 * tracks[f'{m}_ok'].mean():.1f} % | {med} | {st} |")
    lines += _rest_checks(tracks)
    if kin is None:
        # Without a scale there are no kinematics to draw: the tracks are what there is.
        size = (src.get("width"), src.get("height"))
        fig = plot_tracks(tracks, size if all(size) else None, run / TRACKS_FIGURE)
        lines += ["", f"![tracks]({fig.name})"]
    else:
        (run / TRACKS_FIGURE).unlink(missing_ok=True)  # a figure of the pixel-only run before
    cal = info.get("calibration")
    if cal:
        lines += ["", "## Calibration", "", f"method: {cal.get('method')}", ""]
        if "ruler" in cal:
            lines.append(f"- ruler: {cal['ruler']} (X1,Y1,X2,Y2 px = mm)")
        for k in ("mm_per_px", "length_std_mm", "length_relative_spread", "homography_rms_px",
                  "homography_rms_mm", "check_residual_mm", "scale_rel_sigma"):
            if k in cal:
                lines.append(f"- {k}: {cal[k]:.4g}")
    links = info.get("kinematics", {}).get("links")
    if links:
        lines += ["", "## Rigid links", "", "| link | median (mm) | std (mm) | range (mm) | "
                  "frames flagged |", "|---|---|---|---|---|"]
        for k, v in links.items():
            lines.append(f"| {k} | {v['median']:.3f} | {v['std']:.4f} | {v['range']:.4f} | "
                         f"{v['frames_flagged']} |")
    if kin is not None:
        fig = plot_kinematics(kin, comparison, run / KINEMATICS_FIGURE)
        k = info.get("kinematics", {})
        lines += ["", "## Kinematics", "",
                  f"Differentiator window {k.get('window_samples')} samples "
                  f"({k.get('window_s', float('nan')):.3f} s), rate σ scale "
                  f"{k.get('sigma_scale', float('nan')):.3f}.", "", f"![kinematics]({fig.name})"]
    lines += _motion_lines(run, tracks)
    if compare:
        lines += ["", "## Model (spool, fitted)", "", "| parameter | value | 1σ |",
                  "|---|---|---|"]
        for name, v in compare["fitted"].items():
            lines.append(f"| {name} | {v['value']:.5g} {v['unit']} | {v['sigma']:.2g} |")
        lines += ["", "| quantity | RMS error | max error | fit % |", "|---|---|---|---|"]
        for e in compare["errors"]:
            lines.append(f"| {e['quantity']} | {e['rms']:.4g} {e['unit']} | "
                         f"{e['max_abs']:.4g} {e['unit']} | {e['fit_pct']:.2f} |")
        figs = sorted(run.glob("fig_*.png"))
        lines += [""] + [f"![{f.stem}]({f.name})" for f in figs]
    flight = folder.read_json(f"{FIT_DIR}/flight.json")
    if flight:
        base, done = flight["base"], flight["accepted"]
        lines += _loop_section(
            f"## Free flight of {flight['marker']} (`fit --model flight`)",
            f"Parabola: g = {base['g_mm_s2'] / 1e3:.4f} ± {base['g_sigma_mm_s2'] / 1e3:.4f} "
            f"m/s², residual {base['rms_mm']:.3g} mm RMS over {flight['samples']} fixes. ",
            None if done is None else
            f"Accepted: {done} (residual {flight['candidates'][done]['rms_mm']:.3g} mm)"
            + (f", alike: {', '.join(flight['look_alikes'])}" if flight["look_alikes"] else "")
            + ".", "fit/flight.json")
    swing = folder.read_json(f"{FIT_DIR}/swing.json")
    if swing:
        base, done = swing["base"], swing["accepted"]
        g = swing.get("g_mm_s2", {}).get("damped")
        lines += _loop_section(
            f"## Swing of {swing['marker']} (`fit --model pendulum`)",
            f"Damped sinusoid: period {base['period_s']:.5f} ± {base['period_sigma_s']:.5f} s"
            + (f", g = {g[0] / 1e3:.4f} ± {g[1] / 1e3:.4f} m/s² with a string of "
               f"{swing['length_mm']:g} mm" if g else "")
            + f", residual {base['rms']:.3g} {swing['unit']} RMS over {swing['samples']} "
            "samples. ",
            None if done is None else _swing_taken(swing, done), "fit/swing.json")
    turn = folder.read_json(f"{FIT_DIR}/rotation.json")
    if turn:
        base, done = turn["base"], turn["accepted"]
        lines += _loop_section(
            f"## Turn of {turn['marker']} (`fit --model rotation`)",
            f"Steady turn on a circle: ω = {abs(base['omega_rad_s']):.5g} ± "
            f"{base['omega_sigma_rad_s']:.2g} rad/s at the track's middle, residual "
            f"{base['rms']:.3g} {turn['unit']} RMS per axis over {turn['samples']} fixes. ",
            None if done is None else
            f"Accepted, one at a time: {done}; then ω = "
            f"{abs(turn['candidates'][done]['omega_rad_s']):.5g} ± "
            f"{turn['candidates'][done]['omega_sigma_rad_s']:.2g} rad/s, residual "
            f"{turn['candidates'][done]['rms']:.3g} {turn['unit']}.", "fit/rotation.json")
    fit = folder.read_json(f"{FIT_DIR}/{FIT_REPORT_JSON}")
    if fit:
        effects = ", ".join(fit["effects"]) or "none"
        lines += ["", f"## Closing the loop ({fit['model']} model)", "",
                  f"Effects accepted: {effects}. θ RMSE {fit['rmse_before_deg']:.4g}° before, "
                  f"{fit['rmse_after_deg']:.4g}° after; fit {fit['fit_percent_before']:.2f} % → "
                  f"{fit['fit_percent_after']:.2f} %. Details in [fit/report.md](fit/report.md).",
                  "", "![residuals](fit/residuals.png)"]
    if info.get("warnings"):
        lines += ["", "## Warnings", ""] + [f"- {w}" for w in info["warnings"]]
    return write_text_atomic(run / REPORT, "\n".join(lines) + "\n")
