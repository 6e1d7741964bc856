"""`fit --model rotation`: a turning marker's rate, and the effects a steady turn lacks.

Every turn here is a wheel's equation of motion, I·θ'' = −T·sign(θ') − c·θ' (dry and
viscous friction), integrated by scipy's solve_ivp (DOP853, 1e-11) in the test, with
a marker R from the axle, seen by a pinhole camera written here (its plane square to
the camera or tilted). The loop fits closed forms; none of it shares the
integration or the camera.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from cranktrack.errors import CranktrackError
from cranktrack.loop.rotation import fit_rotation, rotation_text

R, NOISE, FPS = 80.0, 0.1, 30.0  # px, px, frames/s


def turn(omega0: float, dry: float = 0.0, viscous: float = 0.0, tilt_deg: float = 0.0,
         seconds: float = 6.0, seed: int = 0, distance: float = 2000.0):
    """Times (s) and a marker's image place (n, 2) px with noise: a wheel let go at
    ``omega0`` rad/s, slowed by ``dry`` rad/s² (a dry friction's torque over the
    inertia) and ``viscous`` /s, its plane turned ``tilt_deg`` about the image's x
    axis, the axle ``distance`` px (focal lengths × R) from a pinhole camera."""
    t = np.arange(int(seconds * FPS)) / FPS

    def rate(_, u):
        return [u[1], -dry * np.sign(u[1]) - viscous * u[1]]

    sol = solve_ivp(rate, (0.0, t[-1]), [0.3, omega0], t_eval=t, rtol=1e-11, atol=1e-12,
                    method="DOP853")
    theta = sol.y[0]
    # The wheel's plane, turned about x: a point (R cos θ, R sin θ, 0) goes to
    # (R cos θ, R sin θ cos i, R sin θ sin i); the camera looks along z from `distance`.
    i = np.radians(tilt_deg)
    X, Y, Z = R * np.cos(theta), R * np.sin(theta) * np.cos(i), R * np.sin(theta) * np.sin(i)
    f = distance  # focal length (px) with the axle `distance` away: 1 px a unit there
    xy = np.c_[400 + f * X / (distance + Z), 300 + f * Y / (distance + Z)]
    return t, xy + np.random.default_rng(seed).normal(0, NOISE, xy.shape)


def test_a_steady_turn_keeps_its_circle_and_its_rate_s_sigma_holds():
    inside = []
    for seed in range(12):
        loop = fit_rotation(*turn(2.0, seed=seed), NOISE)
        assert loop.accepted is None, (seed, loop.delta_bic)
        inside.append(abs(loop.base.omega_rad_s - 2.0) <= loop.base.omega_sigma_rad_s)
    assert 0.5 <= np.mean(inside) <= 0.9, np.mean(inside)


def test_dry_friction_is_a_steady_torque_and_its_rate_of_change_is_found():
    t, xy = turn(6.0, dry=0.5)
    loop = fit_rotation(t, xy, NOISE)
    assert (loop.accepted or "").split(" + ")[0] == "steady torque", loop.delta_bic
    f = loop.final
    assert f.values["alpha_rad_s2"] == pytest.approx(-0.5, rel=0.02)
    # At the track's middle the wheel turns at 6 − 0.5·t rad/s.
    middle = 0.5 * (t[0] + t[-1])
    assert abs(f.omega_rad_s - (6.0 - 0.5 * middle)) <= 3 * f.omega_sigma_rad_s + 1e-4


def test_a_viscous_drag_is_told_from_a_steady_torque():
    t, xy = turn(6.0, viscous=0.25, seconds=8.0)
    loop = fit_rotation(t, xy, NOISE)
    assert (loop.accepted or "").split(" + ")[0] == "viscous drag", (loop.delta_bic,
                                                                     loop.later)
    f = loop.final
    assert f.values["lambda_per_s"] == pytest.approx(0.25, rel=0.02)
    middle = 0.5 * (t[0] + t[-1])
    assert abs(f.omega_rad_s - 6.0 * np.exp(-0.25 * middle)) <= 3 * f.omega_sigma_rad_s + 1e-4
    # A steady torque, fitted to the same turn, is told apart by far.
    assert loop.delta_bic["viscous drag"] - loop.delta_bic["steady torque"] > 100


def test_a_wheel_seen_at_a_slant_is_a_tilted_view_and_keeps_its_rate():
    loop = fit_rotation(*turn(2.0, tilt_deg=30.0), NOISE)
    assert (loop.accepted or "").split(" + ")[0] == "tilted view", loop.delta_bic
    f = loop.final
    # Through a pinhole 25 radii away, the ellipse is cos 30° as narrow to 1 %.
    assert f.narrow_over_wide == pytest.approx(np.cos(np.radians(30)), rel=0.01)
    assert abs(f.omega_rad_s - 2.0) <= 3 * f.omega_sigma_rad_s + 1e-4
    # The circle alone bends its residual at twice the rate, far beyond the noise.
    assert loop.base.rms > 10 * NOISE
    assert "turned 30" in rotation_text(loop, "mark", "px")


def test_too_small_a_turn_is_refused_in_one_sentence():
    t, xy = turn(0.2, seconds=2.0)
    with pytest.raises(CranktrackError, match="a rate needs"):
        fit_rotation(t, xy, NOISE)
    with pytest.raises(CranktrackError, match="at least"):
        fit_rotation(t[:5], xy[:5], NOISE)


def test_the_command_fits_a_tracked_turn(tmp_path, capsys):
    import cranktrack as ct
    from cranktrack.cli import main
    from cranktrack.files import write_csv_atomic, write_json_atomic

    # A run folder as `track` writes it, in px (no scale: a rate needs none), of a wheel
    # slowed by dry friction, turning counterclockwise in its own axes: with the image's
    # y down, clockwise in the picture.
    t, xy = turn(6.0, dry=0.5)
    run = tmp_path / "run"
    run.mkdir()
    write_csv_atomic(run / "tracks.csv", pd.DataFrame({
        "frame": np.arange(t.size), "t_s": t, "mark_x_px": xy[:, 0], "mark_y_px": xy[:, 1],
        "mark_sigma_px": NOISE, "mark_ok": True, "mark_status": "ok"}))
    write_json_atomic(run / "run.json", {"source": {"width": 800, "height": 600}})
    assert main(["fit", str(run), "--model", "rotation", "--marker", "mark"]) == 0
    out = capsys.readouterr().out
    assert "accepted: steady torque" in out and "clockwise in the picture" in out
    assert "counterclockwise" not in out.split("accepted:")[1]
    assert (run / "fit" / "rotation.json").is_file()
    assert "## Turn of mark" in (run / "report.md").read_text()
    half = ct.rotation(run, "mark", end_s=3.0)
    # The first half's middle: 6 − 0.5·t rad/s there.
    middle = 0.5 * (t[0] + t[t <= 3.0][-1])
    assert abs(half.final.omega_rad_s - (6.0 - 0.5 * middle)) <= (
        3 * half.final.omega_sigma_rad_s + 1e-4)
    for args, says in ((["--model", "rotation"], "needs --marker NAME"),
                       (["--model", "rotation", "--marker", "mark", "--length-mm", "3"],
                        "--length-mm is for --model pendulum"),
                       (["--model", "rotation", "--marker", "nope"], "has no marker nope")):
        assert main(["fit", str(run), *args]) != 0
        assert says in capsys.readouterr().err
