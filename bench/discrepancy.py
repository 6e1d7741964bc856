"""Closing the loop on tracked renders: confusion matrix and detection limits.

Renders the spool bed (480×270, 30 fps, 2.5 s, H.264) with one undeclared
effect at a time, at two sizes and two sensor-noise levels, plus null renders
over many seeds; tracks each and runs the loop with the rig's values known
(L1, L2, speed, start and stroke). Prints

- the confusion matrix: true effect × the effect the loop named first;
- the false-discovery rate on null renders;
- per effect, the smallest size detected, over a ladder of sizes at σ 2.5 DN;
- parameter recovery: error / fitted σ and relative error.

Renders are cached in ``bench/.cache/discrepancy``. Run:
``.venv/bin/python bench/discrepancy.py [--seeds N] [--spool-only]`` (about 5 minutes
at 10 seeds for the spool part).
The camera candidates (lens, tilt, rolling shutter) take part whenever the run has its tracks and
calibration, as ``cranktrack fit`` gives them.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

from cranktrack.calibration.known_length import parse_known_length
from cranktrack.environment import versions_line
from cranktrack.loop.frame_motion import frame_shake
from cranktrack.loop.search import close_loop
from cranktrack.models.spool import SpoolDrive
from cranktrack.pipeline import camera_view, track_run
from cranktrack.synthetic.scenarios import FreeScenario, SMAScenario, SpoolScenario
from cranktrack.synthetic.scene import RenderSettings, render_effects

CACHE = Path(__file__).resolve().parent / ".cache" / "discrepancy"
KNOWN = {"L1_mm": 160.8, "L2_mm": 72.4, "speed_mm_s": 14.0, "start_s": 0.5, "stroke_mm": 15.0}
FPS = 30.0

#: effect → (name the loop should give, sizes for the confusion matrix, ladder for limits)
EFFECTS = {
    "slack_mm": ("slack_mm", (0.3, 1.0), (0.02, 0.05, 0.1, 0.2, 0.5)),
    "spool_growth_per_s": ("spool_growth_per_s", (0.03, 0.1), (0.003, 0.01, 0.02, 0.05)),
    "return_spring_hz": ("return_spring_hz", (3.0, 8.0), (12.0, 10.0, 6.0)),
    "fps_label": ("clock_scale", (30.3, 31.0), (30.03, 30.1, 30.3)),
    "wire_stretch_mm": ("wire_stretch_mm", (0.1, 0.5), (0.01, 0.03, 0.1)),
    "k1": ("lens_edge_pct", (-0.05, -0.15), (-0.005, -0.01, -0.02, -0.05)),
    "tilt_deg": ("tilt_vertical_deg", (3.0, 8.0), (0.5, 1.0, 2.0, 4.0)),
    "readout_s": ("readout_s", (0.01, 0.033), (0.002, 0.005, 0.01, 0.02)),
}

#: The rendered effect's size in the loop's parameter: the frame rate's ratio, and the
#: synthetic 60° lens's k1 as the displacement at the half-width, k1·tan²30°, in %.
TRUE_VALUE = {"fps_label": lambda v: v / FPS, "k1": lambda v: 100 * v * np.tan(np.pi / 6) ** 2}

#: The scenes as `cranktrack synth SCENARIO` renders them by default.
SCENARIOS = {
    "spool": lambda: SpoolScenario(SpoolDrive(start_s=0.5, stroke_mm=15.0, speed_mm_s=14.0)),
    "sma": lambda: SMAScenario(on_s=0.5, off_s=3.0),
    "free": lambda: FreeScenario(theta_init_deg=70.0, omega_init_rad_s=0.0),
}


def tracked(name: str, effects: dict[str, float], seed: int, noise: float,
            scenario: str = "spool", size: str = "480x270", seconds: float = 2.5,
            known_length: str = "A-C=160.8") -> Path:
    """Render and track once; the run folder."""
    scene, run = CACHE / name / "scene", CACHE / name / "run"
    if not (run / "kinematics.csv").exists():
        w, h = (int(v) for v in size.split("x"))
        settings = RenderSettings(size=(w, h), fps=FPS, seconds=seconds, noise_dn=noise,
                                  seed=seed)
        files = render_effects(SCENARIOS[scenario](), scene, settings, effects)
        track_run(files.video, run, parse_known_length(known_length))
    return run


#: What the SMA bed's user knows: the current and when it was on (the renders' own).
SMA_KNOWN = {"current_A": 1.3, "current_on_s": 0.5, "current_off_s": 3.0}
#: The heat model's constants as rendered: without them extra pivot damping hides in
#: fitted transformation temperatures and h (see the slow SMA tests).
THERMAL_KNOWN = {"h_W_m2K": 625.0, "As_C": 55.0, "Af_C": 70.0, "Ms_C": 50.0, "Mf_C": 25.0}


def sma_model(seeds: int) -> None:
    """The SMA bed (`synth sma`, 640×360, 5 s, σ 2.5 DN) fitted with the SMA model: null
    renders, and ladders of a thermal lag and of extra pivot damping, undeclared."""
    print("\nSMA model (current known; 640×360, 5 s, σ 2.5 DN):")

    def run_sma(name: str, effects: dict[str, float], seed: int, known: dict) -> dict:
        run = tracked(name, effects, seed, 2.5, "sma", "640x360", 5.0, "A-C=305")
        measured = pd.read_csv(run / "kinematics.csv")
        r = close_loop(measured, known, "sma", view=camera_view(run)).to_dict()
        r["floor_deg"] = floor_deg(run, None)
        return r

    false = sum(bool(run_sma(f"sma_null_s{seed}", {}, seed, SMA_KNOWN)["effects"])
                for seed in range(seeds))
    print(f"  null renders: {false} of {seeds} with a false discovery")
    for effect, ladder, known in (("thermal_lag_s", (0.05, 0.1, 0.2, 0.4), SMA_KNOWN),
                                  ("damping_Nms_rad", (0.02, 0.05, 0.1),
                                   {**SMA_KNOWN, **THERMAL_KNOWN}),
                                  ("coulomb_Nm", (0.01, 0.03, 0.1), SMA_KNOWN)):
        for size in ladder:
            r = run_sma(f"sma_{effect}_{size:g}", {effect: size}, 0, known)
            p = r["parameters"].get(effect)
            got = (f"{p['value']:.4g} ± {p['sigma']:.2g} (z "
                   f"{(p['value'] - size) / p['sigma']:+.2f})" if p and "sigma" in p
                   else "not found")
            print(f"  {effect} = {size:g}: named {r['effects'] or 'nothing'}; {got}; θ RMSE "
                  f"{r['rmse_before_deg']:.4g}° → {r['rmse_after_deg']:.4g}° (floor "
                  f"{r['floor_deg']:.4g}°)", flush=True)


def loop(run: Path, effect: str | None, value: float | None, known: dict | None = None
         ) -> dict:
    known = dict(KNOWN if known is None else known)
    if effect == "fps_label":  # the start is read off the video, on its (wrong) clock
        known["start_s"] = KNOWN["start_s"] * FPS / value
    measured = pd.read_csv(run / "kinematics.csv")
    report = close_loop(measured, known, view=camera_view(run)).to_dict()
    report["floor_deg"] = floor_deg(run, effect)
    return report


def image_angle_deg(table: pd.DataFrame) -> np.ndarray:
    """The angle at A between A→B and A→C in the image, deg, from ``*_px`` columns."""
    a, b, c = (table[[f"{m}_x_px", f"{m}_y_px"]].to_numpy(float) for m in "ABC")
    u, v = b - a, c - a
    return np.degrees(np.arctan2(np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]),
                                 (u * v).sum(axis=1)))


def floor_deg(run: Path, effect: str | None) -> float:
    """The render's noise floor: RMS of the tracked angle against the true one as the
    image shows it (truth.csv's px, which a lens or a tilt bent; with a uniform scale
    that is θ itself). truth.csv holds where the markers were at the frame time, which
    a rolling shutter does not show, so its floor is the same seed's null render's."""
    if effect == "readout_s":
        noise = json.loads((run.parent / "scene" / "scene.json").read_text())["render"]
        run = tracked(f"null_n{noise['noise_dn']:g}_s0", {}, 0, noise["noise_dn"])
    truth = pd.read_csv(run.parent / "scene" / "truth.csv")
    tracks = pd.read_csv(run / "tracks.csv")
    return float(np.sqrt(np.nanmean((image_angle_deg(tracks) - image_angle_deg(truth)) ** 2)))


def dynamic_model(seeds: int) -> None:
    """The free response (`synth free`) fitted with the dynamic model: null renders and
    dry friction at three sizes, nothing known."""
    print("\nDynamic model (free response, nothing known), σ 2.5 DN:")
    false = 0
    for seed in range(seeds):
        run = tracked(f"free_null_s{seed}", {}, seed, 2.5, "free")
        false += bool(close_loop(pd.read_csv(run / "kinematics.csv"), {}, "dynamic",
                                    view=camera_view(run)).effects)
    print(f"  null renders: {false} of {seeds} with a false discovery")
    # The render's dead band is the fitter's play_deg (synthetic/free_swing.py's lever).
    for effect, named, sizes in (("coulomb_rad_s2", "coulomb_rad_s2", (0.05, 0.1, 0.3, 1.0)),
                                 ("dead_band_deg", "play_deg", (0.5, 1.0, 2.0))):
        for size in sizes:
            short = "coulomb" if effect == "coulomb_rad_s2" else "play"
            run = tracked(f"free_{short}_{size:g}", {effect: size}, 0, 2.5, "free")
            r = close_loop(pd.read_csv(run / "kinematics.csv"), {}, "dynamic",
                           view=camera_view(run)).to_dict()
            p = r["parameters"].get(named)
            got = (f"{p['value']:.4g} ± {p['sigma']:.2g} "
                   f"(z {(p['value'] - size) / p['sigma']:+.2f})" if p else "not found")
            print(f"  {effect} = {size:g}: named {r['effects'] or 'nothing'}; {got}; θ RMSE "
                  f"{r['rmse_before_deg']:.4g}° → {r['rmse_after_deg']:.4g}°", flush=True)


def frame_motion(seeds: int) -> None:
    """The frame-motion check (A and C across the A–C line) on the null renders and on a
    shaking frame (5 Hz) at several amplitudes: θ's loop cannot see a shake at all."""
    print("\nFrame motion (pivot_amp_mm at 5 Hz; A and C tracks, not θ):")
    false = 0
    for noise in (2.5, 8.0):
        for seed in range(seeds):
            run = tracked(f"null_n{noise:g}_s{seed}", {}, seed, noise)
            false += frame_shake(pd.read_csv(run / "tracks.csv")).accepted
    print(f"  null renders: {false} of {2 * seeds} with a shake found")
    for noise in (2.5, 8.0):
        for size in (0.05, 0.1, 0.2, 0.3, 1.0):
            run = tracked(f"pivot_amp_mm_{size:g}_n{noise:g}", {"pivot_amp_mm": size}, 0, noise)
            s = frame_shake(pd.read_csv(run / "tracks.csv"))
            verdict = "found" if s.accepted else f"missed ({s.reason})"
            print(f"  σ {noise:g} DN, {size:g} mm: {verdict}; {s.amp_mm:.4g} ± "
                  f"{s.amp_sigma_mm:.2g} mm (z {(s.amp_mm - size) / s.amp_sigma_mm:+.2f}) at "
                  f"{s.hz:.4g} ± {s.hz_sigma:.2g} Hz; across-line RMS {s.rmse_before_mm:.4g} → "
                  f"{s.rmse_after_mm:.4g} mm")


def sindy_terms(run: Path) -> set[str]:
    """Terms PySINDy (SINDy with control, STLSQ) keeps in the equation for θ'' from the
    same measured θ: state (θ − θ_end, θ'), control (drive on, time since start while
    driving), linear library. The drive's start and stop are the known ones."""
    import warnings

    import pysindy as ps

    k = pd.read_csv(run / "kinematics.csv")
    t = k["t_s"].to_numpy(float)
    theta = np.radians(k["theta_deg"].to_numpy(float))
    fd = ps.SmoothedFiniteDifference(smoother_kws={"window_length": 7})
    omega = fd(theta, t)
    start, stop = KNOWN["start_s"], KNOWN["start_s"] + KNOWN["stroke_mm"] / KNOWN["speed_mm_s"]
    drive = ((t > start) & (t < stop)).astype(float)
    x = np.stack([theta - theta[-1], omega], axis=1)
    u = np.stack([drive, drive * (t - start)], axis=1)
    model = ps.SINDy(feature_library=ps.PolynomialLibrary(degree=1),
                     optimizer=ps.STLSQ(threshold=0.05, alpha=1e-3), differentiation_method=fd)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit(x, t=t, u=u, feature_names=["theta", "omega", "drive", "ramp"])
    names = model.get_feature_names()
    return {n for n, c in zip(names, model.coefficients()[1], strict=True) if c != 0}


def sindy_comparison(seeds: int) -> None:
    """How often SINDy keeps the term an effect needs, and how often it keeps it anyway."""
    rows = []
    for noise in (2.5, 8.0):
        for seed in range(seeds):
            rows.append(("none", sindy_terms(tracked(f"null_n{noise:g}_s{seed}", {}, seed,
                                                      noise))))
        for effect in ("return_spring_hz", "spool_growth_per_s"):
            for size in EFFECTS[effect][1]:
                rows.append((effect, sindy_terms(tracked(f"{effect}_{size:g}_n{noise:g}",
                                                         {effect: size}, 0, noise))))
    print("\nPySINDy (SINDy with control) on the same measured θ: terms kept in θ''")
    for label, term in (("return_spring_hz", "theta"), ("spool_growth_per_s", "ramp")):
        hit = [term in terms for e, terms in rows if e == label]
        null = [term in terms for e, terms in rows if e == "none"]
        print(f"  '{term}' (what {label} needs): kept in {sum(hit)} of {len(hit)} renders "
              f"with the effect and in {sum(null)} of {len(null)} without any effect")
    sizes = [len(terms) for _, terms in rows]
    print(f"  terms kept per equation: {min(sizes)}–{max(sizes)} of 5")


#: The mechanism's effects (synthetic/mechanism.py, physics written apart from the fitter):
#: label → (SpoolBed fields per size, the name the loop should give or "unexplained", the
#: fitted parameter and the truth in its units).
def _open_world_cases() -> dict:
    from cranktrack.synthetic.mechanism import SpoolBed

    def growth(g: float) -> dict:
        bed = SpoolBed()
        return {"wire_diameter_mm": g * bed.spool_radius_mm / bed.turn_hz}

    return {
        "slack, lost stroke": ([{"slack_mm": v} for v in (0.3, 1.0, 2.0)], "slack_mm",
                               lambda e: e["slack_mm"]),
        "slack, pure delay": ([{"delay_s": v} for v in (0.02, 0.05, 0.1)], "time_offset_s",
                              lambda e: e["delay_s"]),
        "spool growth": ([growth(v) for v in (0.03, 0.1, 0.3)], "spool_growth_per_s",
                         lambda e: SpoolBed(**e).growth_per_s),
        "wire stretch": ([{"stretch_mm": v} for v in (0.1, 0.3, 1.0)], "wire_stretch_mm",
                         lambda e: e["stretch_mm"]),
        "crank inertia": ([{"ring_hz": v} for v in (10.0, 6.0, 3.0)], "return_spring_hz",
                          lambda e: e["ring_hz"]),
        "clock scale": ([{"clock": v} for v in (1.01, 1.03, 1.1)], "clock_scale",
                        lambda e: e["clock"]),
        "eccentric spool": ([{"eccentricity": v, "spool_radius_mm": 1.0}
                             for v in (0.05, 0.1, 0.2)], "drive_ripple_mm",
                            lambda e: e["eccentricity"] * e["spool_radius_mm"]),
        "dead band": ([{"dead_band_deg": v} for v in (0.5, 1.0, 2.0)], "play_deg",
                      lambda e: e["dead_band_deg"]),
        "servo stall (outside)": ([{"stall_at_s": 0.9, "stall_s": v} for v in (0.05, 0.1, 0.2)],
                                  "unexplained", None),
        "Coulomb friction": ([{"ring_hz": 3.0, "coulomb_rad_s2": v} for v in (0.5, 1.0, 2.0)],
                             "coulomb_rad_s2", lambda e: e["coulomb_rad_s2"]),
    }


def _open_world_row(label: str, fields: dict, expect: str, truth, r: dict) -> dict:
    """One series' line of the open-world table: what was in it, what the loop named,
    and the value it fitted against the truth."""
    rec = {"truth": label, "size": ", ".join(f"{k}={v:g}" for k, v in fields.items()),
           "named": r["effects"], "unexplained": bool(r["unexplained"]), "expect": expect}
    p = r["parameters"].get(expect)
    if truth and p and "sigma" in p:
        true = truth(fields)
        rec["value"], rec["true"] = p["value"], true
        rec["rel_err"] = (p["value"] - true) / (true - (1.0 if expect == "clock_scale" else 0.0))
    if expect == "unexplained" and r["leftover"]:
        rec["signature"] = r["leftover"]["sentence"][:90]
        d = r["leftover"].get("discovery")
        rec["proposed"] = (f"{d['equation']}  (θ RMSE {d['rmse_before_deg']:.3g}° → "
                           f"{d['rmse_after_deg']:.3g}°)" if d else "nothing proposed")
    return rec


def print_open_world(rows: list[dict]) -> None:
    """The confusion matrix, the counts the issue's targets name, the recovered values and
    what the sparse regression proposes outside the library."""
    table = pd.DataFrame(rows)
    table["first"] = table["named"].map(lambda x: x[0] if x else "none")
    table.loc[table["unexplained"] & (table["first"] == "none"), "first"] = "unexplained"
    print("Confusion matrix (rows: effect in the mechanism; columns: named first):")
    print(pd.crosstab(table["truth"], table["first"]).to_string())
    null = table[table["truth"] == "none"]
    eff = table[table["truth"] != "none"]
    inside = eff[eff["expect"] != "unexplained"]
    outside = eff[eff["expect"] == "unexplained"]
    right = (inside["first"] == inside["expect"]).sum()
    alone = inside["named"].map(len).le(1) & (inside["first"] == inside["expect"])
    print(f"\nright family named first: {right} of {len(inside)} "
          f"({100 * right / len(inside):.0f} %)")
    print(f"no extra effect beside the right one: {int(alone.sum())} of {int(right)}")
    print(f"false discoveries on {len(null)} nulls: {int(null['named'].map(bool).sum())}")
    ok = outside["named"].map(len).eq(0) & outside["unexplained"]
    print(f"outside the library, 'unexplained' with no name: {int(ok.sum())} of {len(outside)}"
          f"; a wrong name: {int(outside['named'].map(bool).sum())}")
    cols = [c for c in ("truth", "size", "named", "value", "true", "rel_err", "signature")
            if c in eff]
    print(eff[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print("\nOutside the library, the missing term the sparse regression proposes:")
    for _, row in outside.iterrows():
        print(f"  {row['truth']}, {row['size']}: {row.get('proposed', 'nothing proposed')}")


def open_world(nulls: int) -> None:
    """The loop on θ(t) from :mod:`cranktrack.synthetic.mechanism` (no render, no tracker:
    AR(1) noise of σ 0.02°, lag-1 correlation 0.5, as tracked renders show), every
    effect at three sizes, both physical forms where there are two, effects outside the
    library, and ``nulls`` null series."""
    from cranktrack.synthetic.mechanism import SpoolBed, measured_table

    t = np.arange(75) / FPS
    sigma, rho = 0.02, 0.5

    def run(fields: dict, seed: int) -> dict:
        e = dict(fields)
        clock = e.pop("clock", 1.0)
        bed = SpoolBed(**e)
        true_t = np.maximum(KNOWN["start_s"] + clock * (t - KNOWN["start_s"]), 0.0)
        table = measured_table(bed.theta(true_t), t, sigma, seed=seed, correlation=rho)
        return close_loop(table, KNOWN).to_dict()

    t0 = time.perf_counter()
    rows = []
    for seed in range(nulls):
        r = run({}, 1000 + seed)
        rows.append({"truth": "none", "size": "", "named": r["effects"],
                     "unexplained": bool(r["unexplained"])})
    for label, (sizes, expect, truth) in _open_world_cases().items():
        for i, fields in enumerate(sizes):
            rows.append(_open_world_row(label, fields, expect, truth, run(fields, i)))
    print(f"\nOpen world: the mechanism's physics, in memory, σ {sigma}° with lag-1 "
          f"correlation {rho} ({time.perf_counter() - t0:.0f} s)")
    print_open_world(rows)
    loop_speed()


#: The open world on tracked renders: `synth --effect` names (the spool's physics from
#: synthetic/mechanism.py, the camera's from synthetic/camera.py), what the loop should
#: name, and the true value in its parameter.
RENDERED_CASES = {
    "slack, lost stroke": ([{"slack_mm": v} for v in (0.3, 1.0, 2.0)], "slack_mm",
                           lambda e: e["slack_mm"]),
    "slack, pure delay": ([{"drive_delay_s": v} for v in (0.02, 0.05, 0.1)], "time_offset_s",
                          lambda e: e["drive_delay_s"]),
    "spool growth": ([{"spool_growth_per_s": v} for v in (0.03, 0.1, 0.3)],
                     "spool_growth_per_s", lambda e: e["spool_growth_per_s"]),
    "wire stretch": ([{"wire_stretch_mm": v} for v in (0.1, 0.3, 1.0)], "wire_stretch_mm",
                     lambda e: e["wire_stretch_mm"]),
    "crank inertia": ([{"return_spring_hz": v} for v in (10.0, 6.0, 3.0)], "return_spring_hz",
                      lambda e: e["return_spring_hz"]),
    "clock scale": ([{"fps_label": FPS * v} for v in (1.01, 1.03, 1.1)], "clock_scale",
                    lambda e: e["fps_label"] / FPS),
    "eccentric spool": ([{"spool_eccentricity": v, "spool_radius_mm": 1.0}
                         for v in (0.05, 0.1, 0.2)], "drive_ripple_mm",
                        lambda e: e["spool_eccentricity"] * e["spool_radius_mm"]),
    "dead band": ([{"dead_band_deg": v} for v in (0.5, 1.0, 2.0)], "play_deg",
                  lambda e: e["dead_band_deg"]),
    "Coulomb friction": ([{"return_spring_hz": 3.0, "coulomb_rad_s2": v}
                          for v in (0.5, 1.0, 2.0)], "coulomb_rad_s2",
                         lambda e: e["coulomb_rad_s2"]),
    "lens": ([{"k1": v} for v in (-0.05, -0.1, -0.15)], "lens_edge_pct",
             lambda e: TRUE_VALUE["k1"](e["k1"])),
    "tilt": ([{"tilt_deg": v} for v in (3.0, 5.0, 8.0)], "tilt_vertical_deg",
             lambda e: e["tilt_deg"]),
    "rolling shutter": ([{"readout_s": v} for v in (0.01, 0.02, 0.033)], "readout_s",
                        lambda e: e["readout_s"]),
    "servo stall (outside)": ([{"servo_stall_s": v} for v in (0.05, 0.1, 0.2)],
                              "unexplained", None),
}


def open_world_renders(nulls: int) -> None:
    """The open world on tracked renders (480×270, 30 fps, 2.5 s, σ 2.5 DN, H.264): every
    case of :data:`RENDERED_CASES` at three sizes and ``nulls`` null renders, each
    tracked and looped as `cranktrack fit` does (camera candidates included)."""
    t0 = time.perf_counter()
    rows = []
    for seed in range(nulls):
        r = loop(tracked(f"null_n2.5_s{seed}", {}, seed, 2.5), None, None)
        rows.append({"truth": "none", "size": "", "named": r["effects"],
                     "unexplained": bool(r["unexplained"])})
    for label, (sizes, expect, truth) in RENDERED_CASES.items():
        for i, fields in enumerate(sizes):
            name = "ow_" + "_".join(f"{k}{v:g}" for k, v in fields.items())
            effect = next(iter(fields))
            r = loop(tracked(name, fields, i, 2.5), effect, fields[effect])
            rows.append(_open_world_row(label, fields, expect, truth, r))
            print(f"  {label}, {rows[-1]['size']}: named {r['effects'] or 'nothing'}"
                  + (" (unexplained)" if r["unexplained"] else ""), flush=True)
    print(f"\nOpen world on tracked renders, σ 2.5 DN ({time.perf_counter() - t0:.0f} s)")
    print_open_world(rows)


def loop_speed() -> None:
    """The whole loop's time on a minute of θ (1800 frames), spool and SMA beds, in memory
    (same AR(1) noise as :func:`open_world`)."""
    from cranktrack.synthetic.mechanism import SpoolBed, measured_table

    sigma, rho = 0.02, 0.5
    # The whole loop on a minute of θ (1800 frames, the drive in the middle).
    long_t = np.arange(1800) / FPS
    table = measured_table(SpoolBed(start_s=25.0, slack_mm=1.0).theta(long_t), long_t, sigma,
                           seed=0, correlation=rho)
    t0 = time.perf_counter()
    close_loop(table, {**KNOWN, "start_s": 25.0})
    print(f"\nspool loop on a minute of θ (1800 frames): {time.perf_counter() - t0:.1f} s "
          "(fit only; tracking is bench/speed.py's)")
    # The SMA bed's loop on a minute (current on at 0.5 s, off at 30 s).
    sma = SMAScenario(on_s=0.5, off_s=30.0)
    table = measured_table(sma.motion(long_t).theta, long_t, sigma, seed=0, correlation=rho,
                           L1_mm=sma.bed.L1, L2_mm=sma.bed.L2)
    t0 = time.perf_counter()
    close_loop(table, {"current_A": 1.3, "current_on_s": 0.5, "current_off_s": 30.0}, "sma")
    print(f"sma loop on a minute of θ (1800 frames): {time.perf_counter() - t0:.1f} s (fit only)")


def open_world_models(nulls: int) -> None:
    """The dynamic and SMA models' loops on θ(t) from their beds built apart from the
    fitter (:mod:`cranktrack.synthetic.free_swing`, :mod:`cranktrack.synthetic.sma_rig`),
    in memory with the same AR(1) noise as :func:`open_world`: the free swing's dry
    friction and play, the SMA bed's thermal lag and dry friction, each at several
    sizes, ``nulls`` null series per model, and the dynamic loop's time on a minute
    of θ."""
    from dataclasses import replace as with_

    from cranktrack.synthetic.mechanism import measured_table
    from cranktrack.synthetic.sma_rig import current_step

    sigma, rho = 0.02, 0.5
    current = current_step(1.3, 0.5, 3.0)
    sma_known = {"current_A": 1.3, "current_on_s": 0.5, "current_off_s": 3.0}

    def free(mu: float, seed: int, t: np.ndarray, play_deg: float = 0.0) -> dict:
        sc = FreeScenario()
        crank = with_(sc.crank, friction_rad_s2=mu, play_rad=np.radians(play_deg))
        theta = crank.swing(t, np.radians(sc.theta_init_deg))[0]
        d = sc.dynamics
        table = measured_table(theta, t, sigma, seed=seed, correlation=rho, L1_mm=d.L1,
                               L2_mm=d.L2)
        return close_loop(table, {}, "dynamic").to_dict()

    def free_play(play_deg: float, seed: int, t: np.ndarray) -> dict:
        return free(0.0, seed, t, play_deg)

    def sma(lag: float, seed: int, t: np.ndarray, known: dict = sma_known,
            coulomb_Nm: float = 0.0, delay: float = 0.0) -> dict:
        rig = with_(SMAScenario().rig, thermal_lag_s=lag, coulomb_Nm=coulomb_Nm,
                    strain_delay_s=delay)
        theta = rig.response(t, current)[0]
        table = measured_table(theta, t, sigma, seed=seed, correlation=rho, L1_mm=rig.L1_mm,
                               L2_mm=rig.L2_mm)
        return close_loop(table, known, "sma").to_dict()

    cases = [("dynamic", "coulomb_rad_s2", free, (0.2, 0.4, 0.8), np.arange(180) / FPS),
             ("dynamic", "play_deg", free_play, (0.5, 1.0, 2.0, 4.0), np.arange(180) / FPS),
             ("sma", "thermal_lag_s", sma, (0.1, 0.2, 0.5), np.arange(150) / FPS),
             # The lag's other form, a dead time: the same as the current switched late.
             ("sma", "time_offset_s", lambda d, seed, t: sma(0.0, seed, t, delay=d),
              (0.05, 0.1, 0.2), np.arange(150) / FPS),
             ("sma", "coulomb_Nm", lambda mu, seed, t: sma(0.0, seed, t, coulomb_Nm=mu),
              (0.005, 0.01, 0.015, 0.03, 0.05), np.arange(150) / FPS)]
    done = set()
    for model, effect, run, sizes, t in cases:
        t0 = time.perf_counter()
        if model not in done:  # the nulls once per model
            done.add(model)
            false = sum(bool(run(0.0, 2000 + k, t)["effects"]) for k in range(nulls))
            print(f"\n{model} model, its bed built apart from the fitter (σ {sigma}°, lag-1 "
                  f"correlation {rho}): {false} false discoveries on {nulls} nulls")
        for size in sizes:
            r = run(size, 1, t)
            p = r["parameters"].get(effect, {})
            print(f"  {effect} = {size:g}: named {r['effects'] or 'none'}"
                  + (f", fitted {p['value']:.4g} ({100 * (p['value'] / size - 1):+.1f} %)"
                     if "value" in p else "")
                  + f"; rmse after {r['rmse_after_deg']:.4f}°"
                  + (f"; unexplained: {r['leftover']['sentence'][:80]}" if r["unexplained"]
                     else ""))
        print(f"  ({time.perf_counter() - t0:.0f} s)")
    minute = np.arange(1800) / FPS
    t0 = time.perf_counter()
    free(0.4, 0, minute)
    print(f"\ndynamic loop on a minute of θ (1800 frames): {time.perf_counter() - t0:.1f} s "
          "(fit only)")


def main_bench() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10, help="null renders per noise level (10)")
    ap.add_argument("--frame-only", action="store_true",
                    help="only the frame-motion check (fast: no θ fits)")
    ap.add_argument("--spool-only", action="store_true",
                    help="only the spool model's confusion matrix, nulls and ladders")
    ap.add_argument("--open-world", action="store_true",
                    help="only the loops on physics written apart from the fitter, in memory "
                    "(spool, dynamic and sma beds; about 6 min)")
    ap.add_argument("--open-world-renders", action="store_true",
                    help="only the open world on tracked renders: every effect at three sizes "
                    "and at least 60 null renders (about 15 min the first time; renders are "
                    "cached)")
    ap.add_argument("--loop-speed", action="store_true",
                    help="only the loop's time on a minute of θ, spool and SMA (about 30 s)")
    ap.add_argument("--dynamic-only", action="store_true",
                    help="only the dynamic model's null renders and ladders (free response)")
    ap.add_argument("--sma-only", action="store_true",
                    help="only the SMA model's null renders and ladders (slow: ~2 min a fit)")
    args = ap.parse_args()
    print(f"libraries: {versions_line()}")
    if args.frame_only:
        frame_motion(args.seeds)
        return
    if args.loop_speed:
        loop_speed()
        return
    if args.sma_only:
        sma_model(min(args.seeds, 5))
        return
    if args.dynamic_only:
        dynamic_model(min(args.seeds, 10))
        return
    if args.open_world_renders:
        open_world_renders(max(60, args.seeds))
        return
    if args.open_world:
        open_world(max(60, args.seeds))
        open_world_models(args.seeds)
        return
    t0 = time.perf_counter()
    rows = []
    for noise in (2.5, 8.0):
        for seed in range(args.seeds):
            r = loop(tracked(f"null_n{noise:g}_s{seed}", {}, seed, noise), None, None)
            rows.append({"truth": "none", "size": 0, "noise": noise, "named": r["effects"][:1],
                         "all": r["effects"], "rmse_after": r["rmse_after_deg"],
                         "floor": r["floor_deg"]})
        for effect, (expect, sizes, _) in EFFECTS.items():
            for size in sizes:
                r = loop(tracked(f"{effect}_{size:g}_n{noise:g}", {effect: size}, 0, noise),
                         effect, size)
                rec = {"truth": expect, "size": size, "noise": noise, "named": r["effects"][:1],
                       "all": r["effects"], "rmse_after": r["rmse_after_deg"],
                       "floor": r["floor_deg"]}
                p = r["parameters"].get(expect)
                if p and "sigma" in p:
                    true = TRUE_VALUE.get(effect, lambda v: v)(size)
                    rec["z"] = (p["value"] - true) / p["sigma"]
                    off = 1.0 if effect == "fps_label" else 0.0
                    rec["rel_err"] = (p["value"] - true) / (true - off)
                rows.append(rec)
    table = pd.DataFrame(rows)
    table["first"] = table["named"].map(lambda x: x[0] if x else "none")
    print(f"{len(table)} tracked renders, loop with {', '.join(KNOWN)} known "
          f"({time.perf_counter() - t0:.0f} s)\n")
    print("Confusion matrix (rows: effect rendered, undeclared; columns: named first):")
    print(pd.crosstab(table["truth"], table["first"]).to_string())
    null = table[table["truth"] == "none"]
    print(f"\nnull renders: {int((null['first'] != 'none').sum())} of {len(null)} with a false "
          f"discovery ({100 * (null['first'] == 'none').mean():.0f} % accept nothing)")
    lesser = {"no stroke": {k: v for k, v in KNOWN.items() if k != "stroke_mm"},
              "nothing": {}}
    for label, known in lesser.items():
        false = sum(bool(loop(tracked(f"null_n{noise:g}_s{seed}", {}, seed, noise), None, None,
                              known)["effects"])
                    for noise in (2.5, 8.0) for seed in range(args.seeds))
        print(f"  with {label} known: {false} of {2 * args.seeds} with a false discovery")
    eff = table[table["truth"] != "none"]
    print("\nEffects: named first, recovery and RMSE after vs the render's noise floor")
    cols = ["truth", "size", "noise", "first", "all", "z", "rel_err", "rmse_after", "floor"]
    print(eff[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    ok = eff["first"] == eff["truth"]
    print(f"named first correctly: {int(ok.sum())} of {len(eff)}; |z| ≤ 1.96 in "
          f"{int((eff['z'].abs() <= 1.96).sum())}, ≤ 3 in {int((eff['z'].abs() <= 3).sum())}; "
          f"RMSE after ≤ 1.5× floor in "
          f"{int((eff['rmse_after'] <= 1.5 * eff['floor']).sum())}")
    print("\nDetection limits at σ 2.5 DN (ladder of sizes, smallest first):")
    for effect, (expect, _, ladder) in EFFECTS.items():
        seen = []
        for size in ladder:  # weakest first (a faster ring is a smaller one)
            r = loop(tracked(f"{effect}_{size:g}_n2.5", {effect: size}, 0, 2.5), effect, size)
            seen.append((size, expect in r["effects"]))
        found = [s for s, hit in seen if hit]
        print(f"  {effect}: " + ", ".join(f"{s:g} {'found' if h else 'missed'}"
                                          for s, h in seen)
              + (f" → weakest detected {found[0]:g}" if found else " → none detected"))
    (CACHE / "last.json").write_text(json.dumps(table.drop(columns=["named"])
                                                .to_dict(orient="records"), default=str))
    if args.spool_only:
        return
    open_world(max(60, args.seeds))
    frame_motion(args.seeds)
    dynamic_model(min(args.seeds, 10))
    sma_model(min(args.seeds, 5))
    sindy_comparison(args.seeds)


if __name__ == "__main__":
    main_bench()
