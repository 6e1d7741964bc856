"""The ``cranktrack`` command: parse, call the library, print.

Every error a user can cause ends in one sentence on stderr and a non-zero
exit (1 for bad input, 2 for a bad command line, 130 for Ctrl-C); files
already written stay on disk.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections.abc import Callable, Iterable, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .errors import CranktrackError, RunInterrupted


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"size {text!r} is not WIDTHxHEIGHT, e.g. 1280x720") from None
    if w < 16 or h < 16:
        raise argparse.ArgumentTypeError(f"size {text!r} is too small (at least 16x16)")
    return w, h


def _positive(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not v > 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be positive")
    return v


def _count(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be 0 or more")
    return v


def _non_negative(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not v >= 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be 0 or more")
    return v


def parse_numbers(items: Iterable[str] | None, names: Iterable[str], flag: str, what: str,
                  finite: bool = False) -> dict[str, float]:
    """``["a=1", "b=2.5"]`` → ``{"a": 1.0, "b": 2.5}``, each name one of ``names``.

    ``flag`` and ``what`` word the error (``--effect``, ``a known effect``);
    ``finite`` also refuses NaN and infinities.
    """
    allowed = tuple(names)
    out: dict[str, float] = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or name not in allowed:
            raise CranktrackError(f"{flag} {item!r} is not NAME=VALUE with {what} "
                                  f"({', '.join(allowed)})")
        try:
            out[name] = float(value)
        except ValueError:
            raise CranktrackError(f"{flag} {item!r}: {value!r} is not a number") from None
        if finite and not np.isfinite(out[name]):
            raise CranktrackError(f"{flag} {item!r} is not a finite number")
    return out


def parse_known(items: list[str] | None, model: str = "spool") -> dict[str, float]:
    """``["L1_mm=160.8", "start_s=0.5"]`` → a dict, checked against the model's names."""
    from .loop.simulate import KNOWN_NAMES

    names = KNOWN_NAMES.get(model)
    if names is None:
        raise CranktrackError(f"the {model!r} model cannot be fitted yet; available: "
                              f"{', '.join(KNOWN_NAMES)}")
    return parse_numbers(items, names, "--known", f"a {model} parameter", finite=True)


def parse_effects(items: list[str] | None) -> dict[str, float]:
    """``["slack_mm=2", "k1=-0.1"]`` → ``{"slack_mm": 2.0, "k1": -0.1}``, checked by
    :func:`~cranktrack.synthetic.effects.check_effects`."""
    from .synthetic.effects import EFFECTS, check_effects

    return check_effects(parse_numbers(items, EFFECTS, "--effect", "a known effect"))


def _show_progress() -> bool:
    return sys.stderr.isatty() and not os.environ.get("CI")


@contextmanager
def _progress(desc: str, total: int | None = None, unit: str = "frame"):
    """A tqdm bar on a terminal; nothing in CI or when piped."""
    from tqdm import tqdm

    bar = tqdm(total=total, desc=desc, unit=unit, disable=not _show_progress(),
               file=sys.stderr, leave=False)
    try:
        yield bar
    finally:
        bar.close()


def _add_render_options(p: argparse.ArgumentParser, seconds: float = 2.5,
                        noise: float = 2.5) -> None:
    p.add_argument("--size", type=_size, default=(1280, 720), help="WIDTHxHEIGHT (1280x720)")
    p.add_argument("--fps", type=_positive, default=30.0, help="frame rate (30)")
    p.add_argument("--seconds", type=_positive, default=seconds, help=f"clip length ({seconds})")
    p.add_argument("--noise", type=_non_negative, default=noise,
                   help=f"sensor noise σ in 8-bit DN ({noise})")
    p.add_argument("--seed", type=int, default=0, help="noise seed (0)")
    p.add_argument("--lossless", action="store_true",
                   help="bit-exact RGB H.264 instead of ordinary H.264")
    p.add_argument("--crf", type=int, default=20, help="H.264 quality when lossy (20)")
    p.add_argument("--tilt-deg", type=float, default=0.0,
                   help="camera tilt off the plane normal, degrees (0)")
    p.add_argument("--k1", type=float, default=0.0, help="radial distortion k1 (0; <0 barrel)")
    p.add_argument("--k2", type=float, default=0.0, help="radial distortion k2 (0)")


def _render_settings(args: argparse.Namespace):
    from .synthetic.scene import RenderSettings

    return RenderSettings(size=args.size, fps=args.fps, seconds=args.seconds,
                          noise_dn=args.noise, seed=args.seed, lossless=args.lossless,
                          crf=args.crf)


def _spool_scenario(args: argparse.Namespace):
    from .models.spool import SpoolDrive
    from .synthetic.scenarios import (
        AntagonisticScenario,
        FreeScenario,
        SMAScenario,
        SpoolScenario,
    )

    # Each scenario has its own default current; pass the option only when it was given.
    given = getattr(args, "current_A", None)
    current = {} if given is None else {"current_A": given}
    if getattr(args, "scenario", "spool") == "antagonistic":
        from .models.antagonistic import AntagonisticBed

        return AntagonisticScenario(AntagonisticBed(
            table_mm=args.table_mm, slack_mm=args.slack_mm, **current))
    if getattr(args, "scenario", "spool") == "free":
        return FreeScenario(theta_init_deg=args.theta_init_deg,
                            omega_init_rad_s=args.omega_init_rad_s)
    if getattr(args, "scenario", "spool") == "sma":
        return SMAScenario(on_s=args.current_on_s, off_s=args.current_off_s, **current)
    return SpoolScenario(SpoolDrive(start_s=args.start_s, stroke_mm=args.stroke_mm,
                                    speed_mm_s=args.speed_mm_s))


def _render(args: argparse.Namespace, out: Path):
    from .synthetic.scene import render_effects

    settings = _render_settings(args)
    with _progress("render", settings.n_frames) as bar:
        return render_effects(_spool_scenario(args), out, settings,
                              parse_effects(getattr(args, "effect", None)),
                              tilt_deg=args.tilt_deg, k1=args.k1, k2=args.k2,
                              on_frame=lambda i, n: bar.update(1),
                              declare_effects=getattr(args, "declare_effects", False))


def _camera(args: argparse.Namespace, scenario, pinhole: bool = False):
    from .synthetic.scene import scenario_camera

    return scenario_camera(scenario, args.size, tilt_deg=args.tilt_deg, k1=args.k1, k2=args.k2,
                           pinhole=pinhole)


def cmd_synth(args: argparse.Namespace) -> int:
    if args.scenario == "board":
        return _synth_board(args)
    if args.scenario == "thermal":
        return _synth_thermal(args)
    files = _render(args, Path(args.out))
    print(f"wrote {files.video}, {files.truth.name} and {files.scene.name}")
    return 0


def _synth_thermal(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from .files import ensure_dir, write_csv_atomic, write_json_atomic
    from .models.heat import SMAWire
    from .synthetic.thermal_log import Instruments, standard_experiments, thermal_log

    out = ensure_dir(Path(args.out))
    wire = SMAWire()
    ins = Instruments(thermocouple_tau_s=args.thermocouple_tau_s,
                      thermocouple_hz=args.thermocouple_hz, noise_C=0.1, noise_V=0.002,
                      noise_A=0.001, noise_mm=0.001)
    log = thermal_log(wire, standard_experiments(), ins, seed=args.seed)
    a = write_csv_atomic(out / "thermal_log.csv", log)
    b = write_json_atomic(out / "truth.json", {"wire": asdict(wire), "instruments": asdict(ins)})
    print(f"wrote {a} ({len(log)} rows: a V–I sweep, four c_p steps and a Δh step) and {b.name}")
    return 0


def cmd_thermal_id(args: argparse.Namespace) -> int:
    from .models.heat import SMAWire
    from .models.thermal_id import identify, read_log

    wire = SMAWire(diameter_m=args.diameter_um * 1e-6, length_m=args.length_mm * 1e-3,
                   density_kg_m3=args.density, As_C=args.As, Af_C=args.Af)
    result = identify(read_log(args.log), wire, args.ambient)
    rows = [["parameter", "value", "1σ", "n", "unit"]]
    labels = {"R_ohm": "R (V–I slope)", "h_W_m2K": "h (steady states, eq. 4.26)",
              "cp_integral": "c_p, integral (eq. 4.19)",
              "cp_derivative": "c_p, derivative (eq. 4.20)", "dh": "Δh (eq. 4.25)",
              "cp_integral_thermocouple": "c_p, integral, timed by thermocouple",
              "dh_thermocouple": "Δh, timed by thermocouple"}
    for key, label in labels.items():
        e = getattr(result, key)
        value = f"{e.value:.5g}" if e.n else "not measured"
        rows.append([label, value, "–" if not np.isfinite(e.sigma) else f"{e.sigma:.2g}",
                     str(e.n), e.unit])
    print(f"ambient {result.T_amb_C:.2f} °C; wire d {args.diameter_um:g} µm, "
          f"L {args.length_mm:g} mm, A_s {args.As:g} °C, A_f {args.Af:g} °C")
    print(_format_table(rows))
    print("n: steady stretches for R and h, step tests for c_p and Δh (1σ is their spread, – "
          "for a single test; Δh needs a step that completes the contraction, past A_f). "
          "c_p and Δh are timed by the displacement (contraction start/end, thesis Fig. "
          "4.13); the thermocouple rows show what the thermocouple's lag does.")
    if args.out:
        from .files import write_json_atomic

        print(f"wrote {write_json_atomic(Path(args.out), result.to_dict())}")
    return 0


def _synth_board(args: argparse.Namespace) -> int:
    from .synthetic.board import BoardSpec, intrinsics_views, plane_view, write_views

    # The same camera as `synth spool` with these options (as a pinhole, to photograph boards).
    nx, ny = parse_board(args.board)
    cam = _camera(args, _spool_scenario(args), pinhole=True)
    out = Path(args.out)
    views = write_views(intrinsics_views(cam, BoardSpec((9, 6), 12.0), args.views, args.seed),
                        out, "camera_view")
    plane_board = BoardSpec((nx, ny), args.square_mm)
    plane = write_views([plane_view(cam, plane_board, (3.0, -12.0))], out, "plane_board")
    print(f"wrote {len(views)} photos of a 9x6 chessboard of 12 mm squares for "
          f"`calibrate camera` ({views[0].name} …) and {plane[0].name}, a {nx}x{ny} board of "
          f"{args.square_mm:g} mm squares lying in the mechanism's plane, for `calibrate "
          f"plane`, in {out}")
    return 0


def _track(args: argparse.Namespace, video: Path, out: Path):
    from .calibration.known_length import parse_known_length
    from .pipeline import track_run
    from .tracker.markers import DEFAULT_MARKERS, parse_markers

    known = parse_known_length(args.known_length) if args.known_length else None
    plane = None
    if getattr(args, "calibration", None):
        from .calibration.file import load_calibration

        plane = load_calibration(args.calibration)
    specs = DEFAULT_MARKERS
    if getattr(args, "marker", None):
        specs = parse_markers(args.marker)
    span = _span(getattr(args, "start", None), getattr(args, "end", None))
    with _progress("track") as bar:
        def start(total: int | None) -> None:
            bar.total = total
            bar.refresh()

        return track_run(video, out, known, specs, span=span,
                         fps=getattr(args, "fps_images", None),
                         window_s=args.window_s,
                         fill_gaps_frames=getattr(args, "fill_gaps", 0), calibration=plane,
                         resume=getattr(args, "resume", False), on_start=start,
                         on_frame=lambda i: bar.update(1))


def _print_warnings(warnings: Sequence[str]) -> None:
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)


def cmd_view(args: argparse.Namespace) -> int:
    path = _record(Path(args.run), args.spawn)
    print(f"wrote {path}; open it with `rerun {path}` (pip install rerun-sdk gives the viewer)")
    return 0


def _record(run: Path, spawn: bool, path: Path | None = None) -> Path:
    from .pipeline import record_run

    try:
        return record_run(run, spawn=spawn, path=path)
    except (RuntimeError, OSError) as e:
        if spawn:
            raise CranktrackError(f"could not start the Rerun viewer here ({e}); drop --spawn "
                                  "and open the .rrd file on a machine with a display") from None
        raise


def _time_or_frame(text: str) -> tuple[float, str]:
    """``--start``/``--end``: seconds (``2.5``) or a frame number (``40f``)."""
    raw = text.strip().lower()
    unit = "frame" if raw.endswith("f") else "s"
    try:
        value = float(raw[:-1] if unit == "frame" else raw)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is neither seconds (2.5) nor a frame "
                                         "number (40f)") from None
    if not (np.isfinite(value) and value >= 0) or (unit == "frame" and value != int(value)):
        raise argparse.ArgumentTypeError(f"{text!r} must be a time ≥ 0 s or a whole frame "
                                         "number")
    return value, unit


def _span(start: tuple[float, str] | None, end: tuple[float, str] | None):
    from .tracker.track import Span

    if start is None and end is None:
        return None
    units = {x[1] for x in (start, end) if x is not None}
    if len(units) > 1:
        raise CranktrackError("give --start and --end in the same unit: both seconds or both "
                              "frame numbers (40f)")
    unit = units.pop()
    lo = start[0] if start else 0.0
    hi = end[0] if end else float("inf")
    if hi < lo:
        raise CranktrackError(f"--end ({hi:g}) comes before --start ({lo:g})")
    return Span(lo, hi, unit)


def cmd_inspect(args: argparse.Namespace) -> int:
    from .report.survey import write_survey_png
    from .tracker.survey import survey
    from .tracker.video import open_frames

    video = Path(args.video)
    frame = None
    for f in open_frames(video, fps=args.fps).frames():
        frame = f
        if f.t_s >= args.at:
            break
    if frame is None:
        raise CranktrackError(f"{video} has no frames")
    table = survey(frame.rgb)
    out = Path(args.out) if args.out else video.with_name(video.stem + "_inspect.png")
    write_survey_png(out, frame.rgb, table)
    if table.empty:
        print(f"no compact blob of one colour, white or black in frame {frame.index} "
              f"(t = {frame.t_s:.3f} s); try another --at")
    else:
        rows = [["--marker", "colour", "x px", "y px", "radius px", "shape"]]
        rows += [[r.marker, r["name"], f"{r.x_px:.0f}", f"{r.y_px:.0f}", f"{r.radius_px:.1f}",
                  "disc" if r.disc_like else f"strip (aspect {r.aspect:.1f})"]
                 for _, r in table.iterrows()]
        print(f"frame {frame.index} (t = {frame.t_s:.3f} s): {len(table)} candidate markers, "
              "most marker-like first")
        print(_format_table(rows))
        picks = " ".join(f"--marker {m}" for m in table["marker"].head(3))
        print(f"\nrename the ones you want and track them, e.g.:\n  cranktrack track {video} "
              f"{picks} --out run")
    print(f"wrote {out}")
    return 0


def cmd_track(args: argparse.Namespace) -> int:
    run = _track(args, Path(args.video), Path(args.out))
    if args.rerun:
        spawn = args.rerun == "spawn"
        target = None if spawn or args.rerun == "RUN/run.rrd" else Path(args.rerun)
        rrd = _record(run.folder, spawn, target)
        print(f"wrote {rrd}" + (" and opened the viewer" if spawn else ""))
    _print_warnings(run.warnings)
    found = ", ".join(f"{m} {100 * run.tracks[m + '_ok'].mean():.0f}%"
                      for m in [c[:-3] for c in run.tracks.columns if c.endswith("_ok")])
    print(f"tracked {len(run.tracks)} frames (markers found: {found})")
    if run.calibration is None:
        print("no --known-length or --calibration given: tracks are in pixels only, "
              "no kinematics")
    for f in run.files.values():
        print(f"wrote {f}")
    return 0


def _format_table(rows: list[list[str]]) -> str:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in
                       enumerate(zip(r, widths, strict=True))) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def cmd_demo(args: argparse.Namespace) -> int:
    from .loop.compare import errors_against_drive, spool_model

    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="cranktrack-demo-"))
    scenario = _spool_scenario(args)
    d = scenario.drive
    print(f"Rendering the spool test bed of thesis Table 2.2 (L1 {d.L1} mm, L2 {d.L2} mm, "
          f"L3_0 {d.L3_0} mm, {d.speed_mm_s} mm/s): {args.size[0]}x{args.size[1]}, "
          f"{args.fps:g} fps, {args.seconds:g} s, noise σ {args.noise:g} DN, "
          f"{'lossless' if args.lossless else 'H.264'}")
    files = _render(args, out / "scene")
    args.known_length = f"A-C={d.L1}"
    run = _track(args, files.video, out / "run")
    _print_warnings(run.warnings)
    measured = run.kinematics
    errors = errors_against_drive(measured, d, margin_s=2.5 / args.fps)  # 2 frames each side
    rows = [["quantity", "frames", "RMS error", "max error", "RMS % of peak"]]
    for r in errors.itertuples():
        rows.append([f"{r.quantity} ({r.rows})", str(r.frames), f"{r.rms:.4g} {r.unit}",
                     f"{r.max_abs:.4g} {r.unit}", f"{r.rms_pct_of_peak:.2f}"])
    model = spool_model(d, measured["t_s"].to_numpy())
    rocking_meas = np.nanmax(measured["theta_deg"]) - np.nanmin(measured["theta_deg"])
    rocking_model = np.nanmax(model["theta_deg"]) - np.nanmin(model["theta_deg"])
    print()
    print("Measured vs analytic model (eqs. 2.1-2.5 with the spool drive):")
    print(_format_table(rows))
    print(f"rocking angle: measured {rocking_meas:.3f} deg, model {rocking_model:.3f} deg")
    print("('away from start/stop' leaves out the two frames either side of the drive's "
          "start and stop, where ω steps)")
    from .pipeline import compare_run

    fitted, plots = compare_run(run.folder, {"L1_mm": d.L1, "L2_mm": d.L2,
                                             "speed_mm_s": d.speed_mm_s})
    plots.append(_record(run.folder, spawn=False))
    print()
    print("Spool model fitted to the measured θ(t) (start time, stroke and L3_0_mm free): "
          + ", ".join(f"{k} = {v:.5g} ± {sd:.2g}" for k, (v, sd) in fitted.fit.fitted.items()))
    _print_comparison(fitted)
    from .pipeline import fit_run

    known = {"L1_mm": d.L1, "L2_mm": d.L2, "speed_mm_s": d.speed_mm_s, "start_s": d.start_s,
             "stroke_mm": d.stroke_mm}
    print()
    print("Closing the loop on this run (rig values known: "
          + ", ".join(f"{k} {v:g}" for k, v in known.items()) + "):")
    _print_fit(fit_run(run.folder, "spool", known)[0].to_dict())
    ring = args.demo_ring_hz
    print()
    print(f"The same bed whose crank rings at {ring:g} Hz when the spool starts and stops "
          "(an effect the model lacks, not declared to the fit):")
    args.effect = [f"return_spring_hz={ring}"]
    files2 = _render(args, out / "scene-ring")
    run2 = _track(args, files2.video, out / "run-ring")
    result = fit_run(run2.folder, "spool", known)[0]
    _print_fit(result.to_dict())
    print()
    print(f"outputs: {out}")
    print(f"  scene: {files.video.name}, {files.truth.name}, {files.scene.name} in {files.folder}")
    print(f"  run:   {', '.join(p.name for p in [*run.files.values(), *plots])} in {run.folder}")
    print(f"  loop:  {run2.folder / 'fit' / 'report.md'} (and fit/ in each run)")
    return 0


def _print_comparison(result) -> None:
    rows = [["quantity", "RMS error", "max error", "RMS % of peak", "fit %"]]
    for r in result.summary.itertuples():
        rows.append([r.quantity, f"{r.rms:.4g} {r.unit}", f"{r.max_abs:.4g} {r.unit}",
                     f"{r.rms_pct_of_peak:.2f}", f"{r.fit_pct:.2f}"])
    print(_format_table(rows))


def cmd_compare(args: argparse.Namespace) -> int:
    from .pipeline import compare_run

    known = parse_known(args.known, "spool")
    if not args.fit_speed:
        known.setdefault("speed_mm_s", args.speed_mm_s)
    result, files = compare_run(Path(args.run), known)
    for m in result.fit.messages:
        print(f"note: {m}")
    print("fitted: " + ", ".join(f"{k} = {v:.5g} ± {sd:.2g}"
                                 for k, (v, sd) in result.fit.fitted.items()))
    _print_comparison(result)
    print(f"wrote {', '.join(f.name for f in files)} in {args.run}")
    return 0


def cmd_fit(args: argparse.Namespace) -> int:
    from .pipeline import fit_run

    known = parse_known(args.known, args.model)
    from .report.fit import fit_report

    with _progress(f"fit {args.model}", unit="fit") as bar:
        def fitting(effects: tuple[str, ...]) -> None:
            bar.set_postfix_str(" + ".join(("base", *effects)), refresh=False)
            bar.update(1)

        result, files = fit_run(Path(args.run), args.model, known, on_fit=fitting)
    _print_fit(fit_report(result))
    if args.rerun:
        spawn = args.rerun == "spawn"
        target = None if spawn or args.rerun == "RUN/run.rrd" else Path(args.rerun)
        files.append(_record(Path(args.run), spawn=spawn, path=target))
    print(f"wrote {', '.join(f.name for f in files)} in {args.run} (fit/ for the loop's files)")
    return 0


def _print_fit(report: dict) -> None:
    for m in report["messages"]:
        print(f"note: {m}")
    rows = [["", "θ RMSE (deg)", "max (deg)", "fit %", "residual white"]]
    for label, key in (("before (base model)", "before"), ("after", "after")):
        rows.append([label, f"{report[f'rmse_{key}_deg']:.4g}", f"{report[f'max_{key}_deg']:.4g}",
                     f"{report[f'fit_percent_{key}']:.3f}", str(report[f"residual_white_{key}"])])
    print(_format_table(rows))
    accepted = [c for c in report["candidates"] if c["accepted"]]
    fm = report.get("frame_motion") or {}
    if not accepted:
        print("effects accepted on θ: none (no candidate explains the residual beyond the "
              "noise)")
    if fm.get("accepted"):
        print(f"effect accepted (A and C tracks): pivot_amp_mm: the frame shakes "
              f"{fm['amp_mm']:.4g} ± {fm['amp_sigma_mm']:.2g} mm at {fm['hz']:.4g} ± "
              f"{fm['hz_sigma']:.2g} Hz across A–C, {fm['amp_vector_mm']:.4g} mm as a whole "
              f"(ΔBIC {fm['delta_bic']:.0f}); θ does not see it, v_B does")
    final = report["parameters"]
    for c in accepted:
        values = ", ".join(f"{k} = {final[k]['value']:.4g} ± {final[k]['sigma']:.2g}"
                           for k in c["parameters"])
        print(f"effect accepted (round {c['round']}): {c['name']}: {values} "
              f"(ΔBIC {c['delta_bic']:.0f} when added)")
    for name, d in report.get("effect_docs", {}).items():
        if d["also_looks_like"]:
            print(f"  {name} is also what {d['also_looks_like']}")
    for g in report["look_alike_groups"]:
        print(f"look-alikes: {', '.join(g['effects'])} fit equally well; to tell them apart, "
              f"{g['separated_by']}")
    for n in report["not_separable"]:
        print(f"not tried: {n['name']} needs --known {' or '.join(n['needs'])}")
    if report["unexplained"]:
        print(f"unexplained: {report['unexplained']}")


def parse_board(text: str) -> tuple[int, int]:
    """``--board COLSxROWS`` (inner corners, or squares for ChArUco), e.g. ``9x6``."""
    try:
        nx, ny = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise CranktrackError(f"--board {text!r} is not COLSxROWS, e.g. 9x6") from None
    if nx < 2 or ny < 2:
        raise CranktrackError(f"--board {text!r} needs at least 2 columns and 2 rows")
    return nx, ny


def _board(args: argparse.Namespace):
    from .calibration.camera import Board

    nx, ny = parse_board(args.board)
    if args.charuco:
        return Board("charuco", (nx, ny), args.square_mm, args.marker_mm, args.dictionary)
    return Board("chessboard", (nx, ny), args.square_mm)


def cmd_calibrate_camera(args: argparse.Namespace) -> int:
    from .calibration.camera import calibrate_camera
    from .calibration.file import save_camera

    flags = ("fix_aspect_ratio",) if args.fix_aspect_ratio else ()
    cal = calibrate_camera(args.images, _board(args), flags)
    path = save_camera(args.out, cal)
    K = cal.camera_matrix
    print(f"{len(cal.per_view_rms_px)} views used"
          + (f", board not found in: {', '.join(cal.skipped)}" if cal.skipped else ""))
    print(f"fx {K[0, 0]:.2f}  fy {K[1, 1]:.2f}  cx {K[0, 2]:.2f}  cy {K[1, 2]:.2f} px; "
          f"distortion k1 {cal.distortion[0]:.4f} k2 {cal.distortion[1]:.4f} "
          f"p1 {cal.distortion[2]:.5f} p2 {cal.distortion[3]:.5f} k3 {cal.distortion[4]:.4f}")
    print(f"RMS reprojection error {cal.rms_px:.3f} px")
    for name, e in cal.per_view_rms_px.items():
        flag = "  <- bad view: retake or drop it" if name in cal.bad_views else ""
        print(f"  {name:30s} {e:.3f} px{flag}")
    print(f"wrote {path}")
    return 0


def cmd_calibrate_plane(args: argparse.Namespace) -> int:
    import cv2
    import pandas as pd

    from .calibration.file import load_camera, save_calibration
    from .calibration.plane import board_plane, points_plane

    camera = load_camera(args.camera) if args.camera else None
    if args.points:
        try:
            pts = pd.read_csv(args.points)
            cols = ["x_px", "y_px", "x_mm", "y_mm"]
            pts = pts[cols].to_numpy(float)
        except (OSError, KeyError, ValueError, pd.errors.ParserError) as e:
            raise CranktrackError(f"{args.points} must be a CSV with columns x_px, y_px, x_mm, "
                                  f"y_mm ({e})") from None
        if args.image is None and camera is None:
            raise CranktrackError("give the image size with the plane photo, or --camera")
        size = camera.image_size if camera is not None else None
        if args.image:
            img = cv2.imread(args.image, cv2.IMREAD_GRAYSCALE)
            if img is None:
                raise CranktrackError(f"{args.image} is not an image OpenCV can read")
            size = (img.shape[1], img.shape[0])
        cal = points_plane(pts[:, :2], pts[:, 2:], size, camera)
    else:
        if args.image is None:
            raise CranktrackError("give a photo of the board lying in the mechanism's plane, "
                                  "or --points")
        grey = cv2.imread(args.image, cv2.IMREAD_GRAYSCALE)
        if grey is None:
            raise CranktrackError(f"{args.image} is not an image OpenCV can read")
        cal = board_plane(grey, _board(args), camera)
    path = save_calibration(args.out, cal)
    q = cal.quality
    print(f"plane from {q['points']} points: homography residual "
          f"{q['homography_rms_px']:.3f} px, {q['homography_rms_mm']:.4f} mm; "
          f"scale 1σ {100 * cal.scale_sigma:.3f} %"
          + ("" if camera else " (no --camera: the lens is taken as distortion-free)"))
    print(f"wrote {path}")
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    from .report.sweep import actuator_curve_sweep, linkage_sweep, max_work_sweep

    if args.metric == "actuator-curve":
        sweep, c = actuator_curve_sweep(args.out)
        print(f"blocked force {c['blocked_N']:.1f} N, free stroke {c['free_pct']:.2f} %; work "
              f"{c['work_J_per_m']:.3f} J per metre of wire ({c['linear_work_J_per_m']:.3f} "
              "linearised)")
    elif args.metric == "max-work":
        sweep = max_work_sweep(args.out, args.envelope, args.n)
        for o in sweep.optima:
            print(f"max {o.what.lower()} {o.value:.3f} {o.unit} at T_i = {o.at['T_i (°C)']:.1f} "
                  f"°C, T_f = {o.at['T_f (°C)']:.1f} °C")
    else:
        sweep = linkage_sweep(args.out, args.metric, args.actuator, args.n)
        o = sweep.optima[0]
        print(f"max {o.what.lower()} {o.value:.1f} {o.unit} at L1/L2 = {o.at['L1/L2']:.2f}, "
              f"θ0 = {o.at['θ0 (deg)']:.1f}° (cf. thesis Table 2.6; crank L2 = 1 m)")
    *first, last = sweep.files
    print(f"wrote {', '.join(map(str, first))} and {last}")
    return 0


def cmd_batch(args: argparse.Namespace) -> int:
    from .batch import run_batch
    from .calibration.known_length import parse_known_length

    known = parse_known_length(args.known_length) if args.known_length else None

    def done(row: dict) -> None:
        state = "ok" if row["status"] == "ok" else f"{row['status']}: {row['message']}"
        print(f"{Path(row['video']).name}: {state}", flush=True)

    summary = run_batch(args.pattern, args.out, known, args.compare, args.jobs, args.scheduler,
                        on_done=done, resume=args.resume)
    failed = int((summary["status"] != "ok").sum())
    print(f"{len(summary) - failed} of {len(summary)} videos done; summary in "
          f"{Path(args.out) / 'summary.csv'}")
    return 0 if failed == 0 else 1


def _add_board_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--board", default="9x6",
                   help="chessboard inner corners, or ChArUco squares, COLSxROWS (9x6)")
    p.add_argument("--square-mm", type=_positive, default=25.0, help="square side, mm (25)")
    p.add_argument("--charuco", action="store_true", help="the board is a ChArUco board")
    p.add_argument("--marker-mm", type=_positive, help="ChArUco marker side, mm")
    p.add_argument("--dictionary", default="DICT_6X6_250", help="ArUco dictionary (DICT_6X6_250)")


def _add_scene_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--start-s", type=_non_negative, default=0.5,
                   help="time the spool starts, s (0.5)")
    p.add_argument("--stroke-mm", type=_positive, default=15.0,
                   help="wire wound in, mm; below 17 for Table 2.2 (15)")
    p.add_argument("--speed-mm-s", type=_positive, default=14.0,
                   help="spool speed, mm/s (14.0, Table 2.2)")


def _add_track_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--known-length", metavar="A-C=MM",
                   help="a constant marker distance that sets the scale, e.g. A-C=160.8")
    p.add_argument("--window-s", type=_positive, default=None,
                   help="differentiator window, s (default: chosen from the data)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="cranktrack",
        description="Track coloured markers on a crank-slider and measure its kinematics.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("synth", help="render a synthetic scene with its ground truth")
    p.add_argument("scenario", choices=["spool", "free", "sma", "antagonistic", "board",
                                        "thermal"],
                   help="spool: the Table 2.2 test bed; free: the damped free response of "
                        "chapter 3 in the same geometry; sma: the SMA-actuated bed of Table "
                        "2.3 heated by a current step; antagonistic: the two-wire mechanism "
                        "of chapter 5, one wire heated then the other; board: calibration "
                        "photos of the "
                        "same synthetic camera; thermal: a wire test-bed log for thermal-id "
                        "(thesis Tables 4.2/4.4 constants)")
    p.add_argument("--effect", action="append", metavar="NAME=VALUE",
                   help="switch on an effect the models lack (repeatable): slack_mm, "
                        "spool_growth_per_s, return_spring_hz, return_spring_zeta, "
                        "dropped_frames, fps_label, k1, k2, tilt_deg, exposure_s, readout_s, "
                        "pivot_amp_mm, pivot_hz, coulomb_rad_s2 (free), thermal_lag_s and "
                        "damping_Nms_rad (sma)")
    p.add_argument("--declare-effects", action="store_true",
                   help="list the effects in scene.json (off: data with an undeclared effect)")
    p.add_argument("--theta-init-deg", type=float, default=70.0,
                   help="(free) release angle, degrees (70; the bias spring rests at 90)")
    p.add_argument("--omega-init-rad-s", type=float, default=0.0,
                   help="(free) release angular velocity, rad/s (0)")
    p.add_argument("--current-A", type=_non_negative, default=None,
                   help="(sma) heating current, A (1.3, thesis Fig. 4.5); (antagonistic) "
                   "each wire's, A (1.1: the thesis's 0.8 A holds a 230 µm wire below A_f "
                   "in the heat model)")
    p.add_argument("--table-mm", type=_non_negative, default=5.0,
                   help="(antagonistic) slide-table pre-stress position, mm (5; the thesis "
                   "steps 0 to 12.5)")
    p.add_argument("--slack-mm", type=_non_negative, default=0.2,
                   help="(antagonistic) slack left by fastening the wires, mm (0.2)")
    p.add_argument("--current-on-s", type=_non_negative, default=0.5,
                   help="(sma) when the current is switched on, s (0.5)")
    p.add_argument("--current-off-s", type=_positive, default=3.0,
                   help="(sma) when it is switched off, s (3.0)")
    p.add_argument("--out", required=True, help="output folder")
    _add_render_options(p, seconds=5.0)
    _add_scene_options(p)
    p.add_argument("--board", default="11x5",
                   help="(board) inner corners of the board lying in the plane (11x5)")
    p.add_argument("--square-mm", type=_positive, default=14.0,
                   help="(board) its square side, mm (14)")
    p.add_argument("--views", type=int, default=15, help="(board) camera photos (15)")
    p.add_argument("--thermocouple-tau-s", type=_non_negative, default=0.0,
                   help="(thermal) first-order lag of the thermocouple, s (0)")
    p.add_argument("--thermocouple-hz", type=_positive, default=200.0,
                   help="(thermal) thermocouple reading rate, Hz (200; the thesis's was 2)")
    p.set_defaults(func=cmd_synth)

    p = sub.add_parser("thermal-id", help="identify R, h, c_p and Δh of an SMA wire from a "
                       "test-bed log (thesis §4.4)")
    p.add_argument("log", help="CSV with t_s, voltage_V, current_A, temperature_C, "
                   "displacement_mm")
    p.add_argument("--diameter-um", type=_positive, default=250.0, help="wire diameter (250)")
    p.add_argument("--length-mm", type=_positive, default=115.0, help="wire length (115)")
    p.add_argument("--density", type=_positive, default=6450.0, help="kg/m³ (6450)")
    p.add_argument("--As", type=float, default=55.0, help="austenite start, °C (55)")
    p.add_argument("--Af", type=float, default=70.0, help="austenite finish, °C (70)")
    p.add_argument("--ambient", type=float, default=None,
                   help="ambient °C (default: the steady temperature at zero current)")
    p.add_argument("--out", help="also write the result as JSON here")
    p.set_defaults(func=cmd_thermal_id)

    p = sub.add_parser("inspect", help="show the candidate markers in one frame of a video and "
                       "the --marker that follows each")
    p.add_argument("video", help="video file or folder of images")
    p.add_argument("--at", type=_non_negative, default=0.0, metavar="SECONDS",
                   help="time of the frame to inspect (0: the first)")
    p.add_argument("--fps", type=_positive, help="frame rate of an image folder")
    p.add_argument("--out", help="PNG to write (default: VIDEO_inspect.png beside the video)")
    p.set_defaults(func=cmd_inspect)

    p = sub.add_parser("track", help="track a video into a run folder")
    p.add_argument("video", help="video file, or a folder of numbered images")
    p.add_argument("--out", required=True, help="run folder to write")
    _add_track_options(p)
    p.add_argument("--start", type=_time_or_frame, metavar="S|Nf",
                   help="track from this time (s) or frame number (40f) on")
    p.add_argument("--end", type=_time_or_frame, metavar="S|Nf",
                   help="track up to this time (s) or frame number (40f)")
    p.add_argument("--marker", action="append", metavar="NAME=COLOUR[@X,Y]",
                   help="a marker and its colour: red, green, blue, yellow, …, a hue in "
                        "degrees, #RRGGBB, or white/black (found by contrast); @X,Y says "
                        "where it is at first (px). Repeat per marker. Naming only A, B or "
                        "C recolours them; naming any other tracks exactly the named ones. "
                        "Defaults: A=green B=red C=blue")
    p.add_argument("--calibration", metavar="PLANE.json",
                   help="plane calibration from `cranktrack calibrate plane`; with it, "
                        "--known-length is only checked")
    p.add_argument("--resume", action="store_true",
                   help="continue a run in --out that was interrupted (Ctrl-C)")
    p.add_argument("--rerun", nargs="?", const="RUN/run.rrd", metavar="FILE|spawn",
                   help="also write a Rerun recording (default RUN/run.rrd), or `spawn` a viewer")
    p.add_argument("--fill-gaps", type=_count, default=0, metavar="N",
                   help="interpolate gaps of up to N frames, flagged as interpolated (0: off)")
    p.add_argument("--fps", dest="fps_images", type=_positive,
                   help="frame rate of an image folder (videos use their own timestamps)")
    p.set_defaults(func=cmd_track)

    p = sub.add_parser("calibrate", help="camera intrinsics, or the mechanism's plane")
    cal_sub = p.add_subparsers(dest="what", required=True, metavar="WHAT")
    q = cal_sub.add_parser("camera", help="intrinsics and lens distortion from board photos")
    q.add_argument("images", nargs="+", help="photos of the board in many poses")
    _add_board_options(q)
    q.add_argument("--fix-aspect-ratio", action="store_true", help="force fx = fy")
    q.add_argument("--out", required=True, help="camera calibration file to write (JSON)")
    q.set_defaults(func=cmd_calibrate_camera)
    q = cal_sub.add_parser("plane", help="pixels to mm in the mechanism's plane")
    q.add_argument("image", nargs="?", help="photo of the board lying in the mechanism's plane")
    _add_board_options(q)
    q.add_argument("--camera", help="camera calibration file (undistorts first)")
    q.add_argument("--points", help="CSV of 4+ points: x_px, y_px, x_mm, y_mm (instead of a "
                                    "board)")
    q.add_argument("--out", required=True, help="plane calibration file to write (JSON)")
    q.set_defaults(func=cmd_calibrate_plane)

    p = sub.add_parser("compare", help="fit the spool model to a run and compare")
    p.add_argument("run", help="run folder written by `cranktrack track`")
    p.add_argument("--model", choices=["spool"], default="spool",
                   help="the model to fit (spool: thesis §2.5.2)")
    p.add_argument("--known", action="append", default=[], metavar="NAME=VALUE",
                   help="a value known from the rig, held fixed; the names `fit --known` "
                        "takes: L1_mm, L2_mm, L3_0_mm, stroke_mm, start_s, speed_mm_s "
                        "(repeatable; the others are fitted)")
    p.add_argument("--speed-mm-s", type=_positive, default=14.0,
                   help="spool speed, mm/s, held fixed unless --known sets it (14.0, "
                        "Table 2.2)")
    p.add_argument("--fit-speed", action="store_true",
                   help="fit the speed too (then L1 is held at its measured value)")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("fit", help="fit a model to a run, find the effect it lacks, report "
                       "before and after")
    p.add_argument("run", help="run folder written by `cranktrack track`")
    p.add_argument("--model", choices=["spool", "sma", "dynamic"], default="spool",
                   help="base model (spool: thesis §2.5.2; dynamic: the free response of "
                   "eq. 3.28, e.g. a `synth free` run; sma: the current-heated bed of §2.5.3 "
                   "with the heat model of chapter 4, e.g. a `synth sma` run)")
    p.add_argument("--known", action="append", metavar="NAME=VALUE",
                   help="a value known from the rig, held fixed (repeatable). spool: L1_mm, "
                   "L2_mm, L3_0_mm, speed_mm_s, start_s (drive switched on, video clock), "
                   "stroke_mm; dynamic: theta_init_deg, omega_init_rad_s, k_l, k_s, k_d "
                   "(per unit inertia), theta_rest_deg, L1_mm, L2_mm; sma: current_A and "
                   "current_on_s (required), current_off_s, ambient_C, L1_mm, L2_mm, "
                   "theta0_deg, recovery_strain, h_W_m2K, As_C, Af_C, Ms_C, Mf_C; any "
                   "model: hfov_deg, the lens's horizontal field of view (for the tilt "
                   "candidates; 60 if not given)")
    p.add_argument("--rerun", nargs="?", const="RUN/run.rrd", metavar="FILE|spawn",
                   help="also write the run's Rerun recording with the fit (default "
                   "RUN/run.rrd, or FILE), or open a live viewer with `spawn`")
    p.set_defaults(func=cmd_fit)

    p = sub.add_parser("sweep", help="parametric maps over frame length and starting angle, "
                       "and the SMA wire's actuator curve and work maps")
    p.add_argument("metric", choices=["rocking-angle", "torque", "work", "actuator-curve",
                                      "max-work"],
                   help="a map over (L1/L2, θ0) for --actuator; actuator-curve: the wire's "
                   "force against stroke (Fig. 2.14); max-work: work over start and final "
                   "temperature for --envelope (Figs. 2.18–2.21)")
    p.add_argument("--actuator", default="rigid", choices=["rigid", "linear", "sma", "muscle"])
    p.add_argument("--envelope", default="linear", choices=["linear", "nonlinear"],
                   help="stress–strain–temperature envelope for max-work: eq. 2.10 or "
                   "eqs. 2.6–2.7")
    p.add_argument("--n", type=int, default=200, help="grid points per axis (200; max-work: "
                   "temperatures from M_f 25 to A_f 70 °C)")
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("batch", help="track many videos, one run folder each, and a summary")
    p.add_argument("pattern", help="quoted glob of videos, e.g. 'recordings/*.mp4'")
    p.add_argument("--out", required=True, help="folder for the run folders and summary.csv")
    p.add_argument("--known-length", metavar="A-C=MM", help="scale for every video")
    p.add_argument("--compare", action="store_true", help="also fit the spool model")
    p.add_argument("--jobs", type=int, help="local worker processes (default: all cores)")
    p.add_argument("--scheduler", help="Dask scheduler address to run on, e.g. tcp://host:8786")
    p.add_argument("--resume", action="store_true",
                   help="keep the videos an earlier summary.csv in --out has as ok; run the "
                   "rest, each from where it was interrupted")
    p.set_defaults(func=cmd_batch)

    p = sub.add_parser("view", help="write a run's Rerun recording (RUN/run.rrd)")
    p.add_argument("run", help="run folder written by `cranktrack track`")
    p.add_argument("--spawn", action="store_true", help="also open the Rerun viewer")
    p.set_defaults(func=cmd_view)

    p = sub.add_parser("demo", help="render the default spool scene, track it, compare with "
                                    "the model")
    p.add_argument("--out", help="output folder (default: a new temporary folder)")
    _add_render_options(p)
    _add_scene_options(p)
    p.add_argument("--window-s", type=_positive, default=None,
                   help="differentiator window, s (default: chosen from the data)")
    p.add_argument("--demo-ring-hz", type=_positive, default=2.5,
                   help="return-spring ring of the second, undeclared-effect scene, Hz (2.5)")
    p.set_defaults(func=cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``cranktrack`` console script."""
    args = build_parser().parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except CranktrackError as e:
        _print_warnings(e.warnings)
        print(f"cranktrack: error: {e}", file=sys.stderr)
        return 1
    except RunInterrupted as e:
        hint = ("continue it with the same command and --resume" if e.resumable
                else "no frame was finished, so run it again from the start")
        print(f"cranktrack: interrupted; files already written in {e.folder} are kept; "
              f"{hint}", file=sys.stderr)
        return 130
    except KeyboardInterrupt:
        print("cranktrack: interrupted; files already written are kept", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into e.g. `head`, which stopped reading
        sys.stderr.close()
        return 0


if __name__ == "__main__":
    sys.exit(main())
