"""The ``cranktrack`` command line's grammar: every command, option and default.

Only :mod:`argparse` and the converters that turn one option's text into a value
(a size, a positive number, a time or frame number) live here; :mod:`.cli`
dispatches on ``args.command`` (and ``args.what`` for ``calibrate``). Nothing is
imported that ``cranktrack --help`` would have to wait for.
"""

from __future__ import annotations

import argparse

import numpy as np


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"size {text!r} is not WIDTHxHEIGHT, e.g. 1280x720") from None
    if w < 16 or h < 16:
        raise argparse.ArgumentTypeError(f"size {text!r} is too small (at least 16x16)")
    return w, h


def _number(text: str, whole: bool, zero_ok: bool) -> float:
    """One option's number: a float (or whole number) > 0, or ≥ 0 with ``zero_ok``."""
    try:
        v = int(text) if whole else float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a {'whole ' if whole else ''}number") from None
    if not whole and not np.isfinite(v):  # a whole number is finite, however long
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    if not (v >= 0 if zero_ok else v > 0):
        raise argparse.ArgumentTypeError(
            f"{text!r} must be {'0 or more' if zero_ok else 'positive'}")
    return v


def _positive(text: str) -> float:
    return _number(text, whole=False, zero_ok=False)


def _nonnegative(text: str) -> float:
    return _number(text, whole=False, zero_ok=True)


def _count(text: str) -> int:
    return int(_number(text, whole=True, zero_ok=True))


def _positive_int(text: str) -> int:
    return int(_number(text, whole=True, zero_ok=False))


def _non_negative(text: str) -> float:
    return _number(text, whole=False, zero_ok=True)


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


def _roi(text: str) -> tuple[int, int, int, int]:
    """``--roi X,Y,W,H``: a rectangle of the frame, px (top-left corner, width, height)."""
    try:
        x, y, w, h = (int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not X,Y,W,H in whole pixels, e.g. "
                                         "100,50,640,360") from None
    if x < 0 or y < 0 or w <= 0 or h <= 0:
        raise argparse.ArgumentTypeError(f"{text!r}: X and Y must be ≥ 0, W and H > 0")
    return x, y, w, h


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


def _add_window_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--window-s", type=_positive, default=None,
                   help="differentiator window, s (default: chosen from the data)")


def _add_track_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--known-length", metavar="A-C=MM",
                   help="a constant marker distance that sets the scale, e.g. A-C=160.8")
    p.add_argument("--ruler", metavar="X1,Y1,X2,Y2=MM",
                   help="two points of the frame (px) a known length apart in the plane of "
                        "motion, e.g. a metre stick's ends, 120,40,620,40=1000: sets the "
                        "scale for any markers, which then get their velocity and "
                        "acceleration in motion.csv")
    _add_window_option(p)


def _synth_command(sub: argparse._SubParsersAction) -> None:
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
                        "wire_stretch_mm, drive_delay_s, spool_eccentricity, spool_radius_mm, "
                        "dead_band_deg, "
                        "servo_stall_s, dropped_frames, fps_label, k1, k2, tilt_deg, "
                        "exposure_s, readout_s, pivot_amp_mm, pivot_hz, coulomb_rad_s2 (free, "
                        "or spool with return_spring_hz), thermal_lag_s, strain_delay_s, "
                        "damping_Nms_rad and coulomb_Nm (sma)")
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


def _thermal_id_command(sub: argparse._SubParsersAction) -> None:
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


#: What ``--fps`` says, for every command that reads a video or a folder of pictures.
FPS_HELP = ("the rate the frames were taken at, per second: an image folder's (needed), "
            "or a video's that plays them at another rate (a phone's slow motion or "
            "time-lapse): its own times are scaled to it")


def _inspect_command(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("inspect", help="show the candidate markers in one frame of a video and "
                       "the --marker that follows each")
    p.add_argument("video", help="video file or folder of images")
    p.add_argument("--at", type=_non_negative, default=0.0, metavar="SECONDS",
                   help="time of the frame to inspect (0: the first)")
    p.add_argument("--fps", type=_positive, metavar="FPS",
                   help=FPS_HELP)
    p.add_argument("--most", type=_positive_int, default=12, metavar="N",
                   help="list this many candidates, the most marker-like first (default: 12; "
                   "more when several markers look alike, e.g. a row of paper cups)")
    p.add_argument("--out", help="PNG to write (default: VIDEO_inspect.png beside the video)")
    p.add_argument("--marker", action="append", metavar="NAME=template@X,Y,R",
                   help="a template marker to try before tracking it (see `track`): how far "
                        "its picture stands above its noise, the likest other place in the "
                        "frame, and where it is found 0.2 s later; drawn in the PNG")


def _check_command(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("check", help="track a video as is and again with invisible ±1 DN "
                       "patterns: how far each marker's fixes move, against their σ")
    p.add_argument("video", help="video file or folder of images")
    p.add_argument("--marker", action="append", metavar="NAME=COLOUR[:SHAPE][@X,Y]",
                   help="as for `track` (default: A=green B=red C=blue)")
    p.add_argument("--patterns", type=_positive_int, default=3, metavar="N",
                   help="how many patterns to track it with (default: 3; each costs a track)")
    p.add_argument("--start", type=_time_or_frame, metavar="S|Nf", help="as for `track`")
    p.add_argument("--end", type=_time_or_frame, metavar="S|Nf", help="as for `track`")
    p.add_argument("--roi", type=_roi, metavar="X,Y,W,H", help="as for `track`")
    p.add_argument("--fps", type=_positive, metavar="FPS",
                   help=FPS_HELP)
    p.add_argument("--out", help="also write the table as CSV here")


def _track_command(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("track", help="track a video into a run folder")
    p.add_argument("video", help="video file, or a folder of numbered images")
    p.add_argument("--out", required=True, help="run folder to write")
    _add_track_options(p)
    p.add_argument("--start", type=_time_or_frame, metavar="S|Nf",
                   help="track from this time (s from the video's start, as players "
                        "count it) or frame number (40f; a field of interlaced video, which "
                        "is tracked a field at a time) on")
    p.add_argument("--end", type=_time_or_frame, metavar="S|Nf",
                   help="track up to this time (s) or frame number (40f)")
    p.add_argument("--roi", type=_roi, metavar="X,Y,W,H",
                   help="look for markers only in this rectangle of the frame (px: top-left "
                        "corner, width, height); positions stay in the whole frame's pixels")
    p.add_argument("--marker", action="append", metavar="NAME=COLOUR[:SHAPE][@X,Y]",
                   help="a marker and its colour: red, green, blue, yellow, …, a hue in "
                        "degrees, #RRGGBB, or white/black/grey (found by contrast); @X,Y says "
                        "where it is at first (px). :disc (a printed flat disc) or :blob (a "
                        "ball, an LED, tape) says what it is: A, B, C are discs, others "
                        "blobs, unless said. Repeat per marker. Naming only A, B or "
                        "C recolours them; naming any other tracks exactly the named ones. "
                        "C=none: no slider marker, θ is A→B's angle from the x axis. "
                        "NAME=template@X,Y,R: a marker with no colour of its own (a steel "
                        "ball), followed by its picture within R px of X,Y in the first "
                        "frame. Defaults: A=green B=red C=blue")
    p.add_argument("--calibration", metavar="PLANE.json",
                   help="plane calibration from `cranktrack calibrate plane`; with it, "
                        "--known-length is only checked")
    p.add_argument("--rolling-shutter-ms", type=_nonnegative, default=0.0, metavar="MS",
                   help="the camera reads its rows one after another, over this many ms from "
                        "the top row to the bottom one (a phone or webcam: often 5-30): the "
                        "kinematics take each marker back to its frame's time (default 0: "
                        "all rows at once)")
    p.add_argument("--resume", action="store_true",
                   help="continue a run in --out that was interrupted (Ctrl-C)")
    p.add_argument("--overwrite", action="store_true",
                   help="--out holds another video's run: replace it (its outputs are "
                        "removed first)")
    p.add_argument("--rerun", nargs="?", const="RUN/run.rrd", metavar="FILE|spawn",
                   help="also write a Rerun recording (default RUN/run.rrd), or `spawn` a viewer")
    p.add_argument("--format", choices=("csv", "parquet"), default="csv",
                   help="parquet: also write tracks.parquet and kinematics.parquet (typed, "
                        "smaller and faster to load for long runs) beside the CSV files")
    p.add_argument("--fill-gaps", type=_count, default=0, metavar="N",
                   help="interpolate gaps of up to N frames, flagged as interpolated (0: off)")
    p.add_argument("--fps", dest="fps_images", type=_positive, metavar="FPS", help=FPS_HELP)


def _measure_command(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("measure", help="measure a run's kinematics again from its tracks (a new "
                                       "scale, calibration, window or rolling shutter), "
                                       "without tracking the video again")
    p.add_argument("run", help="run folder written by `cranktrack track`")
    _add_track_options(p)
    p.add_argument("--calibration", metavar="PLANE.json",
                   help="plane calibration from `cranktrack calibrate plane`; with it, "
                        "--known-length is only checked (default: the run's own "
                        "calibration.json, unless --known-length is given)")
    p.add_argument("--rolling-shutter-ms", type=_nonnegative, default=None, metavar="MS",
                   help="the camera's readout from its top row to its bottom row, as in "
                        "`track` (default: the run's; 0 takes it off)")


def _calibrate_command(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("calibrate", help="camera intrinsics, the mechanism's plane, or a "
                                         "rolling shutter's readout")
    cal_sub = p.add_subparsers(dest="what", required=True, metavar="WHAT")
    q = cal_sub.add_parser("camera", help="intrinsics and lens distortion from board photos")
    q.add_argument("images", nargs="+", help="photos of the board in many poses")
    _add_board_options(q)
    q.add_argument("--fix-aspect-ratio", action="store_true", help="force fx = fy")
    q.add_argument("--k3", choices=("auto", "free", "fixed"), default="auto",
                   help="the fifth distortion coefficient: fitted only where the photos call "
                        "for it (auto), always (free: a wide-angle lens), or never (fixed)")
    q.add_argument("--out", required=True, help="camera calibration file to write (JSON)")
    q = cal_sub.add_parser("plane", help="pixels to mm in the mechanism's plane")
    q.add_argument("image", nargs="?", help="photo of the board lying in the mechanism's plane")
    _add_board_options(q)
    q.add_argument("--camera", help="camera calibration file (undistorts first)")
    q.add_argument("--points", help="CSV of 4+ points: x_px, y_px, x_mm, y_mm (instead of a "
                                    "board)")
    q.add_argument("--out", required=True, help="plane calibration file to write (JSON)")
    q = cal_sub.add_parser("readout", help="a rolling shutter's readout time, from a run of "
                                           "two markers on an upright bar shaken sideways, "
                                           "or of a ball tossed square to the camera")
    q.add_argument("run", help="run folder written by `cranktrack track`")
    q.add_argument("--marker", required=True, action="append", metavar="NAME",
                   help="twice: the two markers on one rigid bar held upright and moved "
                        "sideways (e.g. --marker top --marker bottom); once: a marker in free "
                        "flight (e.g. ball)")
    q.add_argument("--start", type=float, metavar="S",
                   help="the motion starts at this time, s (default: the first fix)")
    q.add_argument("--end", type=float, metavar="S",
                   help="the motion ends at this time, s (default: the last fix)")


def _compare_command(sub: argparse._SubParsersAction) -> None:
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


def _fit_command(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("fit", help="fit a model to a run, find the effect it lacks, report "
                       "before and after")
    p.add_argument("run", help="run folder written by `cranktrack track`")
    p.add_argument("--model", choices=["spool", "sma", "dynamic", "flight", "pendulum",
                                        "rotation"],
                   default="spool",
                   help="base model (spool: thesis §2.5.2; dynamic: the free response of "
                   "eq. 3.28, e.g. a `synth free` run; sma: the current-heated bed of §2.5.3 "
                   "with the heat model of chapter 4, e.g. a `synth sma` run; flight: a body "
                   "tossed or dropped, --marker NAME, in a run with a scale: g from a "
                   "parabola, then a rolling shutter, drags and a turned plane tried in turn; "
                   "pendulum: a bob on a string, --marker NAME: its period (and g with "
                   "--length-mm) from a damped sinusoid, then a quadratic drag, a wide "
                   "swing's slowing, a drift, a turned plane and an elliptical swing tried "
                   "in turn; rotation: a marker on a turning body, --marker NAME: its rate "
                   "from a steady turn on a circle, then a steady torque, a viscous drag, a "
                   "tilted view and a moving axis tried in turn)")
    p.add_argument("--marker", metavar="NAME",
                   help="--model flight, pendulum or rotation: the body in flight, the "
                   "bob, or the marker on the turning body")
    p.add_argument("--start", type=_time_or_frame, metavar="S|Nf",
                   help="--model flight, pendulum or rotation: the first frame (s, or a "
                   "frame "
                   "number: 8f)")
    p.add_argument("--end", type=_time_or_frame, metavar="S|Nf",
                   help="--model flight, pendulum or rotation: the last frame")
    p.add_argument("--length-mm", type=_positive, metavar="MM",
                   help="--model pendulum: the string's length, pivot to the bob's centre "
                   "(g from the period)")
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


def _sweep_command(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sweep", help="parametric maps over frame length and starting angle, "
                       "and the SMA wire's actuator curve and work maps")
    p.add_argument("metric", choices=["rocking-angle", "torque", "work", "actuator-curve",
                                      "max-work"],
                   help="a map over (L1/L2, θ0) for --actuator; actuator-curve: the wire's "
                   "force against stroke (Fig. 2.14); max-work: work over start and final "
                   "temperature for --envelope (Figs. 2.18–2.21)")
    p.add_argument("--actuator", default="rigid", choices=["rigid", "linear", "sma", "muscle"],
                   help="what pulls the wire for the (L1/L2, θ0) maps: rigid, a fixed 5 %% "
                   "contraction (rocking angle only); sma, the 250 µm wire's actuator curve; "
                   "linear, its straight-line fit; muscle, the same shape over a 13.75 %% "
                   "stroke (default: rigid)")
    p.add_argument("--envelope", default="linear", choices=["linear", "nonlinear"],
                   help="stress–strain–temperature envelope for max-work: eq. 2.10 or "
                   "eqs. 2.6–2.7")
    p.add_argument("--n", type=int, default=200, help="grid points per axis (200; max-work: "
                   "temperatures from M_f 25 to A_f 70 °C)")
    p.add_argument("--out", required=True, help="output folder")


def _batch_command(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("batch", help="track many videos, one run folder each, and a summary")
    p.add_argument("pattern", help="quoted glob of videos, e.g. 'recordings/*.mp4'")
    p.add_argument("--out", required=True, help="folder for the run folders and summary.csv")
    p.add_argument("--known-length", metavar="A-C=MM", help="scale for every video")
    p.add_argument("--ruler", metavar="X1,Y1,X2,Y2=MM",
                   help="scale for every video from two points of the frame a known length "
                        "apart, as for `track`: summary.csv then has each marker's median "
                        "acceleration")
    p.add_argument("--marker", action="append",
                   metavar="NAME=COLOUR[:SHAPE][@X,Y] | NAME=template@X,Y,R",
                   help="the markers of every video, as for `track` (default: A=green B=red "
                        "C=blue)")
    p.add_argument("--fps", type=_positive, metavar="FPS",
                   help="the rate every video was taken at, as for `track` (default: each "
                        "video's own clock)")
    p.add_argument("--rolling-shutter-ms", type=_nonnegative, default=0.0, metavar="MS",
                   help="the camera's readout from its top row to its bottom row, as in "
                        "`track` (default 0: all rows at once)")
    p.add_argument("--compare", action="store_true", help="also fit the spool model")
    p.add_argument("--jobs", type=int, help="local worker processes (default: all cores)")
    p.add_argument("--scheduler", help="Dask scheduler address to run on, e.g. tcp://host:8786")
    p.add_argument("--resume", action="store_true",
                   help="keep the videos an earlier summary.csv in --out has as ok; run the "
                   "rest, each from where it was interrupted")


def _view_command(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("view", help="write a run's Rerun recording (RUN/run.rrd)")
    p.add_argument("run", help="run folder written by `cranktrack track`")
    p.add_argument("--spawn", action="store_true", help="also open the Rerun viewer")


def _demo_command(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="render the default spool scene, track it, compare with "
                                    "the model")
    p.add_argument("--out", help="output folder (default: ./demo-output, replaced on each "
                                  "run)")
    _add_render_options(p)
    _add_scene_options(p)
    _add_window_option(p)
    p.add_argument("--demo-ring-hz", type=_positive, default=2.5,
                   help="return-spring ring of the second, undeclared-effect scene, Hz (2.5)")


def _add_quiet(p: argparse.ArgumentParser) -> None:
    p.add_argument("--quiet", action="store_true",
                   help="no progress bars (they are shown only on a terminal anyway)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="cranktrack",
        description="Track coloured markers on a crank-slider and measure its kinematics.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _synth_command(sub)
    _thermal_id_command(sub)
    _inspect_command(sub)
    _track_command(sub)
    _check_command(sub)
    _measure_command(sub)
    _calibrate_command(sub)
    _compare_command(sub)
    _fit_command(sub)
    _sweep_command(sub)
    _batch_command(sub)
    _view_command(sub)
    _demo_command(sub)
    for name in ("synth", "track", "check", "compare", "fit", "batch", "demo"):  # with progress
        _add_quiet(sub.choices[name])
    return parser
