"""The ``cranktrack`` command: parse (the grammar is :mod:`.arguments`), call the
library, print.

Every error a user can cause ends in one sentence on stderr and a non-zero
exit (1 for bad input, 2 for a bad command line, 130 for Ctrl-C); files
already written stay on disk.
"""

from __future__ import annotations

import argparse
import os
import shlex
import shutil
import sys
from collections.abc import Callable, Iterable, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .arguments import build_parser
from .errors import CranktrackError, RunInterrupted
from .report.console import (
    comparison_text,
    drive_errors_text,
    fit_text,
    format_table,
    reproducibility_text,
)

if TYPE_CHECKING:  # the command imports its tracker lazily: start-up stays short
    from .tracker.video import Frame

#: Where `cranktrack demo` writes when given no --out: under the folder it is run from.
DEMO_FOLDER = "demo-output"


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
    from .loop.simulate import known_names

    return parse_numbers(items, known_names(model), "--known", f"a {model} parameter",
                         finite=True)


def parse_effects(items: list[str] | None) -> dict[str, float]:
    """``["slack_mm=2", "k1=-0.1"]`` → ``{"slack_mm": 2.0, "k1": -0.1}``, checked by
    :func:`~cranktrack.synthetic.effects.check_effects`."""
    from .synthetic.effects import EFFECTS, check_effects

    return check_effects(parse_numbers(items, EFFECTS, "--effect", "a known effect"))


#: Set from --quiet by :func:`main`: the one switch the progress bars read.
_QUIET = False


def _show_progress() -> bool:
    return sys.stderr.isatty() and not os.environ.get("CI") and not _QUIET


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
    print(format_table(rows))
    print("n: steady stretches for R and h, step tests for c_p and Δh (1σ is their spread, – "
          "for a single test; Δh needs a step that completes the contraction, past A_f). "
          "c_p and Δh are timed by the displacement (contraction start/end, thesis Fig. "
          "4.13); the thermocouple rows show what the thermocouple's lag does.")
    for sentence in result.caveats():
        print(f"note: {sentence}")
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
    from .calibration.ruler import parse_ruler
    from .pipeline import track_run
    from .tracker.markers import DEFAULT_MARKERS, parse_markers

    known = parse_known_length(args.known_length) if args.known_length else None
    ruler = parse_ruler(args.ruler) if getattr(args, "ruler", None) else None
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
                         roi=_roi(getattr(args, "roi", None)),
                         fps=getattr(args, "fps_images", None),
                         window_s=args.window_s,
                         fill_gaps_frames=getattr(args, "fill_gaps", 0), calibration=plane,
                         resume=getattr(args, "resume", False), on_start=start,
                         overwrite=getattr(args, "overwrite", False),
                         table_format=getattr(args, "format", "csv"),
                         readout_s=getattr(args, "rolling_shutter_ms", 0.0) / 1e3,
                         ruler=ruler, on_frame=lambda i: bar.update(1),
                         on_stage=lambda stage: bar.set_description_str(f"track: {stage}"))


def cmd_check(args: argparse.Namespace) -> int:
    from .files import ensure_dir, write_csv_atomic
    from .tracker.markers import DEFAULT_MARKERS, parse_markers
    from .tracker.reproducibility import Patterned, reproducibility
    from .tracker.track import track
    from .tracker.video import open_frames

    specs = parse_markers(args.marker) if args.marker else DEFAULT_MARKERS
    span, roi = _span(args.start, args.end), _roi(args.roi)
    if args.out:
        ensure_dir(Path(args.out).parent)  # said before minutes of tracking, not after
    results = []
    with _progress("check") as bar:
        for k, seed in enumerate([None, *range(args.patterns)]):
            source = open_frames(Path(args.video), fps=args.fps)
            if source.shown_frames and span is None:  # with a span, unknown
                bar.total = source.shown_frames * (args.patterns + 1)
            bar.set_description_str("check: as is" if seed is None else
                                    f"check: pattern {k} of {args.patterns}")
            results.append(track(source if seed is None else Patterned(source, seed), specs,
                                 on_frame=lambda i: bar.update(1), span=span, roi=roi))
    table = reproducibility(results[0].tracks, [r.tracks for r in results[1:]],
                            [s.name for s in specs])
    print(reproducibility_text(table, args.video, len(results[0].tracks), args.patterns))
    if args.out:
        print(f"wrote {write_csv_atomic(Path(args.out), table)}")
    return 0


def cmd_measure(args: argparse.Namespace) -> int:
    from .calibration.known_length import parse_known_length
    from .calibration.ruler import parse_ruler
    from .pipeline import measure_run
    from .run_folder import RUN_INFO, RunFolder, out_of_date

    plane = None
    if args.calibration:
        from .calibration.file import load_calibration

        plane = load_calibration(args.calibration)
    readout = None if args.rolling_shutter_ms is None else args.rolling_shutter_ms / 1e3
    run = measure_run(args.run, parse_known_length(args.known_length) if args.known_length
                      else None, plane, args.window_s, readout,
                      ruler=parse_ruler(args.ruler) if args.ruler else None)
    _print_warnings(run.warnings)
    q = run.calibration.quality
    scale = (f"{q['mm_per_px']:.5g} mm/px" if "mm_per_px" in q else run.calibration.method)
    info = RunFolder(run.folder).read_json(RUN_INFO) or {}
    readout_s = (info.get("tracking") or {}).get("rolling_shutter_readout_s")
    print(f"measured {len(run.motion)} rows from the tracks ({scale}, "
          + (f"rolling shutter {readout_s * 1e3:g} ms" if readout_s else "all rows at once")
          + ")")
    print(f"wrote {', '.join(f.name for f in run.files.values())} in {run.folder}")
    # A compare or fit made before now stands on the kinematics replaced: say so.
    _print_warnings(out_of_date(run.folder, ["compare", "fit"]))
    return 0


def _print_warnings(warnings: Sequence[str]) -> None:
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)


def cmd_view(args: argparse.Namespace) -> int:
    from .run_folder import out_of_date

    _print_warnings(out_of_date(args.run))
    path = _record(Path(args.run), args.spawn)
    print(f"wrote {path}; open it with `rerun {path}` (pip install rerun-sdk gives the viewer)")
    return 0


def _record(run: Path, spawn: bool, path: Path | None = None) -> Path:
    """Write the run's recording; where --spawn cannot open a viewer, say so in one
    warning and go on (the file is written)."""
    from .errors import ViewerUnavailableError
    from .pipeline import record_run

    try:
        return record_run(run, spawn=spawn, path=path)
    except ViewerUnavailableError as e:
        _print_warnings([str(e)])
        return Path(e.path)


def _roi(xywh: tuple[int, int, int, int] | None):
    from .tracker.track import Roi

    return None if xywh is None else Roi(*xywh)


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


def _placed_templates(items: list[str], frame: Frame, later: Frame | None
                      ) -> list[tuple[str, float, float, float]]:
    """Print what each template marker of ``items`` (``--marker NAME=template@X,Y,R``)
    would follow in ``frame`` and find in ``later``; return them to be drawn."""
    from .tracker.markers import parse_markers
    from .tracker.template import (
        LEAST_SCORE,
        PLAIN_CONTRAST,
        judge_placement,
        nearly_as_like,
    )

    placed = []
    for spec in parse_markers(items) if items else ():
        if spec.template_radius_px is None:
            raise CranktrackError(f"--marker {spec.name}: inspect lists colour and tone "
                                  "markers itself; --marker here tries a template marker, "
                                  "NAME=template@X,Y,R")
        (x, y), r = spec.near_px, spec.template_radius_px
        w, h = frame.size
        try:
            seen = judge_placement(frame.luma(0, 0, w, h), (x, y), r,
                                   None if later is None else later.luma(0, 0, w, h))
        except ValueError:
            raise CranktrackError(f"--marker {spec.name}: its picture within {r:g} px of "
                                  f"({x:g}, {y:g}) reaches past the {w}×{h} frame") from None
        label = f"{spec.name}=template@{x:g},{y:g},{r:g}"
        contrast = seen.template.contrast
        print(f"{label}: its picture stands {contrast:.1f}× above its noise "
              f"({'plain: nothing to follow' if seen.template.plain else 'enough'}"
              f"; plain under {PLAIN_CONTRAST:g}×)")
        rx, ry, rs = seen.rival
        print(f"  the likest other place in this frame, ({rx:.0f}, {ry:.0f}), matches it "
              f"{rs:.2f}" + (": nearly as well as the marker itself, so where it is lost it "
                             "is sought only near where it was; a radius that takes in more "
                             "of what only it shows makes it surer"
                             if nearly_as_like(seen.template, rs) else ""))
        if later is not None:
            found = seen.later
            print(f"  {later.t_s - frame.t_s:.3f} s later it is likest at "
                  + (f"no place (no match of {LEAST_SCORE:g} or more)" if found is None else
                     f"({found.x:.1f}, {found.y:.1f}), matching {found.score:.2f}"))
        placed.append((label, x, y, r))
    return placed


def cmd_inspect(args: argparse.Namespace) -> int:
    from .files import ensure_dir
    from .report.survey import write_survey_png
    from .tracker.lighting import settling_note
    from .tracker.marker_state import rig_focus_note
    from .tracker.pictures import sequence_of
    from .tracker.survey import crank_slider, frame_and_later, rig_edges, survey
    from .tracker.video import colourless_note, open_frames

    video = Path(args.video)
    # A second frame a little later tells what moves: what people film markers for.
    source = open_frames(video, fps=args.fps, one_picture=True)
    frame, later = frame_and_later(source.frames(), lambda f: f.t_s >= args.at)
    # What the reader says of the file (turned, interlaced, non-square pixels) holds
    # for the picture and every place in it.
    for note in dict.fromkeys([*source.problems, colourless_note(source)]):
        if note:
            print(note)
    # One picture of a numbered sequence: the commands below track its folder, and the
    # PNG is not written in among the frames.
    sequence = sequence_of(video)
    clip = video.parent if sequence else video
    if frame is None:
        raise CranktrackError(f"{video} has no frames")
    if frame.t_s < args.at:
        print(f"the clip ends before --at {args.at:g} s: its last frame is shown")
    table = survey(frame.rgb, most=args.most, later=None if later is None else later.rgb)
    if later is not None and (note := settling_note(frame.light, later.light, frame.t_s,
                                                     later.t_s)):
        print(note)
    out = Path(args.out) if args.out else clip.with_name(
        (f"{clip.name}_{video.stem}" if sequence else video.stem) + "_inspect.png")
    placed = _placed_templates(args.marker or [], frame, later)
    ensure_dir(out.parent)
    write_survey_png(out, frame.rgb, table, placed)
    if table.empty:
        print(f"no compact blob of one colour, white or black in frame {frame.index} "
              f"(t = {frame.t_s:.3f} s); try another --at")
    else:
        rows = [["--marker", "colour", "x px", "y px", "radius px", "shape", "moves"]]
        rows += [[r.marker, r["name"], f"{r.x_px:.0f}", f"{r.y_px:.0f}", f"{r.radius_px:.1f}",
                  r["shape"] + (f", on {r.on}" if r.on else ""),
                  "-" if later is None else ("yes" if r.moves else "no")]
                 for _, r in table.iterrows()]
        print(f"frame {frame.index} (t = {frame.t_s:.3f} s): {len(table)} candidate markers, "
              "most marker-like first")
        print(format_table(rows))
        # A highlight or the cap of a ball is not suggested: the ball is.
        whole = table[table["on"] == ""]
        picks = " ".join(f"--marker {m}" for m in (whole if len(whole) else table)["marker"]
                         .head(3))
        # A folder of pictures has no clock: the command needs the rate given here.
        fps = f" --fps {args.fps:g}" if args.fps else " --fps FPS" if sequence else ""
        # The places are this frame's, and @X,Y is where a marker is when tracking
        # starts: a falling ball placed where it is a second in is never there at first.
        if frame.index > 0:
            fps += f" --start {frame.index}f"
        # Quoted, so that a path with spaces (Tracker's examples have them) pastes.
        rig = crank_slider(table)
        if rig is not None:
            named = " ".join(f"--marker {m}" for m in rig.values())
            print("\na green, a red and a blue disc: the crank-slider's A, B and C. Track "
                  "them under those names (then the wire across them is allowed for and "
                  "the kinematics know which is which), with the A–C length you measured:"
                  f"\n  cranktrack track {shlex.quote(str(clip))}{fps} {named} "
                  "--known-length A-C=MM --out run")
            if note := rig_focus_note(rig_edges(frame, table)):
                print(note)
        print("\nrename the ones you want and track them, e.g.:\n  cranktrack track "
              f"{shlex.quote(str(clip))}{fps} {picks} --out run")
        if rig is None:
            print("(for kinematics name them A, the pivot, B, the crank's tip, and C, the "
                  "slider, or C=none; an A, B or C that is no printed disc, such as an LED or "
                  "a ball, takes :blob after its colour: B=green:blob@X,Y)")
            print("(for mm, each marker's velocity and acceleration, and g from a flight "
                  "(`cranktrack fit RUN --model flight --marker NAME`), add --ruler "
                  "X1,Y1,X2,Y2=MM: the ends of a known length in this picture, px, and "
                  "that length; a swing's period and a turning marker's rate need none: "
                  "`--model pendulum` or `--model rotation`)")
        if sequence and not args.fps:
            print(f"({video.name} is one of {sequence} numbered pictures: the command tracks "
                  "their folder; FPS is the rate they were taken at)")
    print(f"wrote {out}")
    return 0


def _pixels_only(folder: str, names: list[str]) -> str:
    """What a run tracked with no scale lacks, and the command that adds it without
    tracking again, for the markers it tracked (``names``): the crank-slider's A–C (or
    A–B) length, or for other markers a ruler, two points of the frame a known length
    apart."""
    said = "no --known-length, --ruler or --calibration given: tracks are in pixels only"
    if {"A", "B"} <= set(names):
        pair = "A-C" if "C" in names else "A-B"
        return (f"{said}, no kinematics (add them with `cranktrack measure {folder} "
                f"--known-length {pair}=MM`, without tracking again)")
    return (f"{said}; add mm and each marker's velocity and acceleration (motion.csv) with "
            f"`cranktrack measure {folder} --ruler X1,Y1,X2,Y2=MM`, the ends of a known length "
            "in the picture (px) and that length, without tracking again")


def cmd_track(args: argparse.Namespace) -> int:
    run = _track(args, Path(args.video), Path(args.out))
    if args.rerun:
        spawn = args.rerun == "spawn"
        target = None if spawn or args.rerun == "RUN/run.rrd" else Path(args.rerun)
        rrd = _record(run.folder, spawn, target)
        print(f"wrote {rrd}")
    _print_warnings(run.warnings)
    names = [c[:-3] for c in run.tracks.columns if c.endswith("_ok")]
    found = ", ".join(f"{m} {100 * run.tracks[m + '_ok'].mean():.0f}%" for m in names)
    print(f"tracked {len(run.tracks)} frames (markers found: {found})")
    if run.calibration is None:
        print(_pixels_only(shlex.quote(str(run.folder)), names))
    print(f"wrote {', '.join(f.name for f in run.files.values())} in {run.folder}")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    from .files import replace_folder
    from .loop.compare import errors_against_drive, spool_model

    out = Path(args.out) if args.out else replace_folder(DEMO_FOLDER, ".cranktrack-demo")
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
    model = spool_model(d, measured["t_s"].to_numpy())
    rocking_meas = np.nanmax(measured["theta_deg"]) - np.nanmin(measured["theta_deg"])
    rocking_model = np.nanmax(model["theta_deg"]) - np.nanmin(model["theta_deg"])
    print()
    print("Measured vs analytic model (eqs. 2.1-2.5 with the spool drive):")
    print(drive_errors_text(errors))
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
    print(comparison_text(fitted))
    from .pipeline import fit_run

    known = {"L1_mm": d.L1, "L2_mm": d.L2, "speed_mm_s": d.speed_mm_s, "start_s": d.start_s,
             "stroke_mm": d.stroke_mm}
    print()
    print("Closing the loop on this run (rig values known: "
          + ", ".join(f"{k} {v:g}" for k, v in known.items()) + "):")
    print(fit_text(fit_run(run.folder, "spool", known)[0].to_dict()))
    ring = args.demo_ring_hz
    print()
    print(f"The same bed whose crank rings at {ring:g} Hz when the spool starts and stops "
          "(an effect the model lacks, not declared to the fit):")
    args.effect = [f"return_spring_hz={ring}"]
    files2 = _render(args, out / "scene-ring")
    run2 = _track(args, files2.video, out / "run-ring")
    result = fit_run(run2.folder, "spool", known)[0]
    print(fit_text(result.to_dict()))
    print()
    print(f"outputs: {out}")
    print(f"  scene: {files.video.name}, {files.truth.name}, {files.scene.name} in {files.folder}")
    names = dict.fromkeys(p.name for p in [*run.files.values(), *plots])  # once each, in order
    print(f"  run:   {', '.join(names)} in {run.folder}")
    print(f"  loop:  {run2.folder / 'fit' / 'report.md'} (and fit/ in each run)")
    print(f"next: cranktrack view {run.folder}  (the recording, in the Rerun viewer)")
    hint = _path_hint()
    if hint:
        print(hint)
    return 0


def _path_hint() -> str:
    """A sentence on how to type ``cranktrack`` when this one is not on PATH (run from a
    virtual environment that is not activated, as ``make demo`` does); else ''."""
    here = Path(sys.argv[0]).resolve() if sys.argv and sys.argv[0] else None
    found = shutil.which("cranktrack")
    if here is None or here.name != "cranktrack" or (found and Path(found).resolve() == here):
        return ""
    activate = here.parent / "activate"
    if activate.is_file():
        return (f"cranktrack is not on your PATH: run `source {os.path.relpath(activate)}` "
                f"first, or type {os.path.relpath(here)} instead of cranktrack")
    return f"cranktrack is not on your PATH: type {here} instead of cranktrack"


def cmd_compare(args: argparse.Namespace) -> int:
    from .pipeline import compare_run

    known = parse_known(args.known, "spool")
    if not args.fit_speed:
        known.setdefault("speed_mm_s", args.speed_mm_s)
    from .run_folder import out_of_date

    _print_warnings(out_of_date(args.run, ["track"]))
    with _progress("compare", 3, unit="step") as bar:
        def stage(name: str) -> None:
            if name != "fit":  # the step before it is done
                bar.update(1)
            bar.set_description_str(f"compare: {name}")

        result, files = compare_run(Path(args.run), known, on_stage=stage)
        bar.update(1)
    for m in result.fit.messages:
        print(f"note: {m}")
    print("fitted: " + ", ".join(f"{k} = {v:.5g} ± {sd:.2g}"
                                 for k, (v, sd) in result.fit.fitted.items()))
    print(comparison_text(result))
    print(f"wrote {', '.join(f.name for f in files)} in {args.run}")
    return 0


def _fit_flight(args: argparse.Namespace) -> int:
    from .loop.flight import flight_text
    from .pipeline import fit_flight_run
    from .run_folder import out_of_date

    if args.known:
        raise CranktrackError("--known is for the crank-slider's models; a flight has none")
    if not args.marker:
        raise CranktrackError("--model flight needs --marker NAME, the body in flight")
    _print_warnings(out_of_date(args.run, ["track"]))
    loop, files = fit_flight_run(Path(args.run), args.marker,
                                 _span(args.start, args.end))
    print(flight_text(loop, args.marker))
    print(f"wrote {', '.join(f.name for f in files)} in {Path(args.run)} (fit/ for the "
          "flight's files)")
    return 0


def _fit_swing(args: argparse.Namespace) -> int:
    from .loop.swing import swing_text
    from .pipeline import fit_swing_run
    from .run_folder import out_of_date

    if args.known:
        raise CranktrackError("--known is for the crank-slider's models; a pendulum takes "
                              "--length-mm")
    if not args.marker:
        raise CranktrackError("--model pendulum needs --marker NAME, the bob")
    _print_warnings(out_of_date(args.run, ["track"]))
    loop, unit, arc_px, files = fit_swing_run(Path(args.run), args.marker,
                                              _span(args.start, args.end), args.length_mm)
    print(swing_text(loop, args.marker, unit, args.length_mm))
    if arc_px is not None and args.length_mm is not None:
        print(f"(no scale: the swing's angle is its width over the radius of its arc, "
              f"{arc_px:.0f} px, the circle through the bob's path)")
    print(f"wrote {', '.join(f.name for f in files)} in {Path(args.run)} (fit/ for the "
          "swing's files)")
    return 0


def _fit_rotation(args: argparse.Namespace) -> int:
    from .loop.rotation import rotation_text
    from .pipeline import fit_rotation_run
    from .run_folder import out_of_date

    if args.known:
        raise CranktrackError("--known is for the crank-slider's models; a turn has none")
    if not args.marker:
        raise CranktrackError("--model rotation needs --marker NAME, the marker on the "
                              "turning body")
    _print_warnings(out_of_date(args.run, ["track"]))
    loop, unit, files = fit_rotation_run(Path(args.run), args.marker,
                                         _span(args.start, args.end))
    print(rotation_text(loop, args.marker, unit))
    print(f"wrote {', '.join(f.name for f in files)} in {Path(args.run)} (fit/ for the "
          "turn's files)")
    return 0


def cmd_fit(args: argparse.Namespace) -> int:
    from .pipeline import fit_run

    if args.model in ("flight", "rotation"):
        if args.length_mm is not None:
            raise CranktrackError("--length-mm is for --model pendulum")
        return _fit_flight(args) if args.model == "flight" else _fit_rotation(args)
    if args.model == "pendulum":
        return _fit_swing(args)
    if args.marker or args.start or args.end or args.length_mm is not None:
        raise CranktrackError("--marker, --start, --end and --length-mm are for --model "
                              "flight, pendulum or rotation")
    known = parse_known(args.known, args.model)
    from .report.fit import fit_report
    from .run_folder import out_of_date

    _print_warnings(out_of_date(args.run, ["track"]))

    with _progress(f"fit {args.model}", unit="fit") as bar:
        def fitting(effects: tuple[str, ...]) -> None:
            bar.set_postfix_str(" + ".join(("base", *effects)), refresh=False)
            bar.update(1)

        result, files = fit_run(Path(args.run), args.model, known, on_fit=fitting)
    print(fit_text(fit_report(result)))
    if args.rerun:
        spawn = args.rerun == "spawn"
        target = None if spawn or args.rerun == "RUN/run.rrd" else Path(args.rerun)
        files.append(_record(Path(args.run), spawn=spawn, path=target))
    print(f"wrote {', '.join(f.name for f in files)} in {args.run} (fit/ for the loop's files)")
    return 0


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
    from .calibration.camera import K3_BIC, calibrate_camera
    from .calibration.file import save_camera

    flags = ("fix_aspect_ratio",) if args.fix_aspect_ratio else ()
    cal = calibrate_camera(args.images, _board(args), flags, args.k3)
    path = save_camera(args.out, cal)
    K, sd = cal.camera_matrix, cal.sigma
    print(f"{len(cal.per_view_rms_px)} views used"
          + (f", board not found in: {', '.join(cal.skipped)}" if cal.skipped else ""))
    print(f"fx {K[0, 0]:.2f} ± {sd.get('fx', np.nan):.2f}  fy {K[1, 1]:.2f} ± "
          f"{sd.get('fy', np.nan):.2f}  cx {K[0, 2]:.2f} ± {sd.get('cx', np.nan):.2f}  "
          f"cy {K[1, 2]:.2f} ± {sd.get('cy', np.nan):.2f} px; "
          f"distortion k1 {cal.distortion[0]:.4f} k2 {cal.distortion[1]:.4f} "
          f"p1 {cal.distortion[2]:.5f} p2 {cal.distortion[3]:.5f} k3 {cal.distortion[4]:.4f}")
    if np.isfinite(cal.k3_delta_bic):
        held = "fix_k3" in cal.flags
        print(f"k3 {'held at 0' if held else 'fitted'}: the BIC gained by fitting it is "
              f"{cal.k3_delta_bic:.1f}, {'not ' if held else ''}above {K3_BIC:g}"
              + (" (--k3 free fits it anyway)" if held else ""))
    print(f"RMS reprojection error {cal.rms_px:.3f} px")
    for w in cal.warnings:
        print(f"warning: {w}")
    for name, e in cal.per_view_rms_px.items():
        flag = "  <- bad view: retake or drop it" if name in cal.bad_views else ""
        print(f"  {name:30s} {e:.3f} px{flag}")
    print(f"wrote {path}")
    return 0


def cmd_calibrate_plane(args: argparse.Namespace) -> int:
    import pandas as pd

    from .calibration.camera import read_grey
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
            img = read_grey(args.image)
            size = (img.shape[1], img.shape[0])
        cal = points_plane(pts[:, :2], pts[:, 2:], size, camera)
    else:
        if args.image is None:
            raise CranktrackError("give a photo of the board lying in the mechanism's plane, "
                                  "or --points")
        cal = board_plane(read_grey(args.image), _board(args), camera)
    path = save_calibration(args.out, cal)
    q = cal.quality
    print(f"plane from {q['points']} points: homography residual "
          f"{q['homography_rms_px']:.3f} px, {q['homography_rms_mm']:.4f} mm; "
          f"scale 1σ {100 * cal.scale_sigma:.3f} %"
          + ("" if camera else " (no --camera: the lens is taken as distortion-free)"))
    print(f"wrote {path}")
    return 0


def cmd_calibrate_readout(args: argparse.Namespace) -> int:
    from .pipeline import readout_from_run

    if len(args.marker) > 2:
        raise CranktrackError("give --marker once (a ball in free flight) or twice (two "
                              f"markers on one upright bar), not {len(args.marker)} times")
    if len(args.marker) == 2:
        return _readout_from_pair(args)
    fit = readout_from_run(args.run, args.marker[0], args.start, args.end)
    print(f"{args.marker[0]} in free flight, {fit.fixes} fixes: a readout of "
          f"{fit.readout_s * 1e3:.2f} ± {fit.readout_sigma_s * 1e3:.2f} ms over "
          f"{fit.height_px} rows; residual {fit.residual_px:.3f} px a coordinate "
          f"({fit.residual_global_px:.3f} with all rows at the frame's time), acceleration "
          f"{fit.acceleration_px_s2:.1f} px/s² ({fit.acceleration_global_px_s2:.1f})")
    if fit.tilt_explains_it:
        print(f"but a flight plane turned to the camera, all rows read at once, leaves "
              f"{fit.residual_tilted_px:.3f} px, no more: one toss cannot tell the two apart, "
              "so the readout holds only if the ball flew square to the camera (in a drawn "
              "toss, a plane turned by 10° passed for a readout of 18 ms)")
    if fit.readout_s <= 2.0 * fit.readout_sigma_s:
        print("that is within 2σ of reading all rows at once: no --rolling-shutter-ms "
              "needed (or the flight chosen is not free: see --start and --end)")
    else:
        print(("if it did, " if fit.tilt_explains_it else "") + _readout_option(fit.readout_s))
    return 0


def _readout_from_pair(args: argparse.Namespace) -> int:
    from .pipeline import readout_from_run

    first, second = args.marker
    fit = readout_from_run(args.run, first, args.start, args.end, second=second)
    print(f"{first} and {second} on one bar, {fit.fixes} frames: a readout of "
          f"{fit.readout_s * 1e3:.2f} ± {fit.readout_sigma_s * 1e3:.2f} ms over "
          f"{fit.height_px} rows; their separation scatters by {fit.residual_px:.3f} px a "
          f"coordinate about the bar's own with it ({fit.residual_global_px:.3f} with all rows "
          "at the frame's time)")
    if fit.residual_px > 0.5:
        print("that scatter is large: the bar may have turned or come nearer while moving; "
              "keep it upright, at one distance, and move it sideways only")
    if abs(fit.readout_s) <= 2.0 * fit.readout_sigma_s:
        print("that is within 2σ of reading all rows at once: no --rolling-shutter-ms needed")
    elif fit.readout_s < 0:
        print("a negative readout: this camera reads the picture's rows from the bottom up "
              "(is it mounted upside down?); --rolling-shutter-ms takes top to bottom only")
    else:
        print(_readout_option(fit.readout_s))
    return 0


def _readout_option(readout_s: float) -> str:
    """The options that give a readout (s) found by `calibrate readout` to a run."""
    ms = f"{readout_s * 1e3:.2f}"
    return (f"track this camera with: --rolling-shutter-ms {ms} (a run already tracked: "
            f"cranktrack measure RUN --rolling-shutter-ms {ms})")


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
    from .calibration.ruler import parse_ruler
    from .tracker.markers import parse_markers

    known = parse_known_length(args.known_length) if args.known_length else None
    # Parsed here, so that a --marker or --ruler mistyped is said once, before any video
    # is opened.
    specs = parse_markers(args.marker) if args.marker else None
    ruler = parse_ruler(args.ruler) if args.ruler else None

    with _progress("batch", unit="video") as bar:
        def start(n: int) -> None:
            bar.total = n
            bar.refresh()

        def done(row: dict) -> None:
            state = "ok" if row["status"] == "ok" else f"{row['status']}: {row['message']}"
            bar.write(f"{Path(row['video']).name}: {state}", file=sys.stdout)
            bar.update(1)

        summary = run_batch(args.pattern, args.out, known, args.compare, args.jobs,
                            args.scheduler, on_done=done, resume=args.resume, on_start=start,
                            readout_s=args.rolling_shutter_ms / 1e3, specs=specs,
                            fps=args.fps, ruler=ruler)
    failed = int((summary["status"] != "ok").sum())
    print(f"{len(summary) - failed} of {len(summary)} videos done; summary in "
          f"{Path(args.out) / 'summary.csv'}")
    return 0 if failed == 0 else 1


#: What each command line runs (``calibrate`` by what it calibrates).
COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "synth": cmd_synth, "thermal-id": cmd_thermal_id, "inspect": cmd_inspect,
    "track": cmd_track, "check": cmd_check, "measure": cmd_measure, "compare": cmd_compare,
    "fit": cmd_fit,
    "sweep": cmd_sweep, "batch": cmd_batch, "view": cmd_view, "demo": cmd_demo,
    "calibrate camera": cmd_calibrate_camera, "calibrate plane": cmd_calibrate_plane,
    "calibrate readout": cmd_calibrate_readout,
}


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``cranktrack`` console script."""
    global _QUIET
    try:
        args = build_parser().parse_args(argv)
        _QUIET = bool(getattr(args, "quiet", False))
        key = f"calibrate {args.what}" if args.command == "calibrate" else args.command
        return COMMANDS[key](args)
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
