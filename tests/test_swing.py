"""`fit --model pendulum`: a swing's period, g from it, and the effect a damped
sinusoid lacks.

Every swing here is the pendulum's equation of motion, θ'' = −(g/L)·sin θ − b·θ' −
k·|θ'|·θ', integrated by scipy's solve_ivp (DOP853, 1e-11) in the test and seen
sideways as L·sin θ. The loop fits envelopes and rates in closed form; none of it
shares the integration.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp
from scipy.special import ellipk

from cranktrack.errors import CranktrackError
from cranktrack.loop.swing import fit_swing, swing_text

G, L, NOISE = 9810.0, 1000.0, 0.2  # mm/s², mm, mm


def swing(theta0: float, b: float = 0.0, k: float = 0.0, drift: float = 0.0,
          seconds: float = 20.0, fps: float = 30.0, seed: int = 0):
    """Times (s) and the bob's sideways place (mm) with noise, from rest at θ0 (rad)."""
    t = np.arange(int(seconds * fps)) / fps

    def rate(_, u):
        return [u[1], -(G / L) * np.sin(u[0]) - b * u[1] - k * abs(u[1]) * u[1]]

    sol = solve_ivp(rate, (0.0, t[-1]), [theta0, 0.0], t_eval=t, rtol=1e-11, atol=1e-12,
                    method="DOP853")
    x = L * np.sin(sol.y[0]) + drift * t
    return t, x + np.random.default_rng(seed).normal(0, NOISE, t.size)


def test_a_small_damped_swing_keeps_its_sinusoid_and_g_s_sigma_holds():
    inside = []
    for seed in range(12):
        loop = fit_swing(*swing(0.05, b=0.02, seed=seed), NOISE)
        assert loop.accepted is None, (seed, loop.delta_bic)
        g, sigma = loop.base.g(L)
        inside.append(abs(g - G) <= sigma)
    assert 0.5 <= np.mean(inside) <= 0.9, np.mean(inside)


def test_a_wide_swing_s_period_is_taken_back_to_a_small_one_s():
    # At 0.4 rad the period is 1 % longer than a small swing's: g 2 % low without
    # the elliptic integral's correction.
    loop = fit_swing(*swing(0.4), NOISE)
    g, sigma = loop.base.g(L)
    assert abs(g - G) <= 3 * sigma
    small = 2 * np.pi * np.sqrt(L / G)
    assert loop.base.period_s == pytest.approx(small * 1.0102, rel=1e-3)


@pytest.mark.parametrize("effect, kwargs", [
    ("quadratic drag", {"theta0": 0.2, "k": 0.3}),
    ("drift", {"theta0": 0.1, "b": 0.02, "drift": 2.0}),
    ("large swing", {"theta0": 0.6, "b": 0.15}),
])
def test_what_bends_a_swing_is_named_and_g_is_found_again(effect, kwargs):
    loop = fit_swing(*swing(**kwargs), NOISE)
    # The effect drawn is taken first; a swing that dies down from 0.2 rad also speeds
    # up as it narrows, and the loop may take that next.
    first = (loop.accepted or "").split(" + ")[0]
    assert effect == first or effect in loop.look_alikes, loop.delta_bic
    for fit in (loop.candidates[effect], loop.final):
        g, sigma = fit.g(L)
        assert abs(g - G) <= 3 * sigma + 1e-3 * G, (fit.effect, g, sigma)
    assert effect in swing_text(loop, "bob", "mm", L)


def test_too_short_a_swing_is_refused_in_one_sentence():
    with pytest.raises(CranktrackError, match="under two swings"):
        fit_swing(*swing(0.1, seconds=3.0), NOISE)


def shortening_swing(theta0: float, b: float, shorter: float, seconds: float = 20.0,
                     fps: float = 30.0, seed: int = 0):
    """As :func:`swing`, on a string that shortens steadily by the fraction ``shorter``
    over the track (creeping up its clamp): its rate rises as its swing narrows, with no
    wide swing to make it."""
    t = np.arange(int(seconds * fps)) / fps

    def length(s):
        return L * (1.0 - shorter * s / seconds)

    def rate(s, u):
        return [u[1], -(G / length(s)) * np.sin(u[0]) - b * u[1]]

    sol = solve_ivp(rate, (0.0, t[-1]), [theta0, 0.0], t_eval=t, rtol=1e-11, atol=1e-12,
                    method="DOP853")
    x = length(t) * np.sin(sol.y[0])
    return t, x + np.random.default_rng(seed).normal(0, NOISE, t.size)


@pytest.mark.parametrize("shorter", [0.006, 0.01])
def test_a_rate_that_rises_for_another_cause_is_no_wide_swing_once_the_length_is_known(
        shorter):
    # A real clip's swing (bartekpacia/pendulum) sped up by 0.3 % as it narrowed by 15 %;
    # a free β took that for a wide swing on a string a quarter of its arc's length, and
    # g came out 3 % above the sinusoid's. A swing of 0.1 rad whose string shortens
    # does the same.
    t, x = shortening_swing(0.1, 0.02, shorter)
    assert fit_swing(t, x, NOISE).accepted == "large swing"
    held = fit_swing(t, x, NOISE, L)
    assert held.accepted is None or "large swing" not in held.accepted, held.delta_bic


def test_a_wide_swing_is_still_taken_with_its_length_known():
    loop = fit_swing(*swing(0.6, b=0.15), NOISE, L)
    assert (loop.accepted or "").split(" + ")[0] == "large swing", loop.delta_bic
    g, sigma = loop.final.g(L)
    assert abs(g - G) <= 3 * sigma + 1e-3 * G, (g, sigma)
    with pytest.raises(CranktrackError, match="not a positive length"):
        fit_swing(*swing(0.6, b=0.15), NOISE, -L)


def seen_swing(theta0: float, across: float, yaw_deg: float, distance: float,
               focal_px: float, seconds: float = 20.0, fps: float = 30.0, seed: int = 0):
    """Times (s) and a pinhole camera's image x (px, with noise) of a bob on a sphere
    (a spherical pendulum, no drag) let go at θ0 (rad) along x, pushed across (along y)
    so that its ellipse is ``across`` times as narrow as it is wide. The camera is
    ``distance`` mm from the pivot's vertical, level with it, turned by ``yaw_deg``
    about the vertical."""
    t = np.arange(int(seconds * fps)) / fps

    def rate(_, u):
        r, v = u[:3], u[3:]
        tension = (v @ v - G * r[2]) / L**2  # keeps |r| = L: r·r'' = −|v|²
        return np.r_[v, -G * np.array([0.0, 0.0, 1.0]) - tension * r]

    start = np.r_[L * np.sin(theta0), 0.0, -L * np.cos(theta0),
                  0.0, across * L * np.sin(theta0) * np.sqrt(G / L), 0.0]
    sol = solve_ivp(rate, (0.0, t[-1]), start, t_eval=t, rtol=1e-11, atol=1e-9,
                    method="DOP853")
    x, y = sol.y[0], sol.y[1]
    yaw = np.radians(yaw_deg)
    side, depth = x * np.cos(yaw) + y * np.sin(yaw), distance - x * np.sin(yaw) + y * np.cos(yaw)
    return t, focal_px * side / depth + np.random.default_rng(seed).normal(0, 0.05, t.size)


def test_a_swing_turned_to_the_camera_and_across_it_is_found_in_turn():
    # Tracker's pendulum clip left 2.8 px of a twice-the-rate residual that way, 12× the
    # tracker's σ, with no one effect explaining it. Here the camera is turned 12° from
    # the swing's plane and the bob swings across a tenth of its width.
    theta0, yaw, distance, focal = 0.1, 12.0, 3000.0, 1200.0
    t, x = seen_swing(theta0, 0.1, yaw, distance, focal)
    loop = fit_swing(t, x, 0.05)
    assert set(loop.accepted.split(" + ")[:2]) == {"turned plane", "elliptical swing"}, (
        loop.delta_bic, loop.later)
    final = loop.final
    assert final.rms < 0.1 < loop.base.rms
    # u / (1 + τ·u): τ is tan(yaw) over the focal length; μ·A the ellipse's narrow
    # half-width over the distance.
    assert abs(final.values["turn_per_unit"]) * focal == pytest.approx(
        np.tan(np.radians(yaw)), rel=0.1)
    narrow = 0.1 * L * np.sin(theta0)
    assert abs(final.values["across_per_unit"] * final.values["amplitude"]) == pytest.approx(
        narrow / distance, rel=0.2)
    # No drag: the period is a plane swing's of θ0, but for the ellipse's own share:
    # seen from the side, a turning ellipse runs faster by about (3/8)·θ_across², 4e-5.
    period = 4 * np.sqrt(L / G) * ellipk(np.sin(theta0 / 2) ** 2)
    assert abs(final.period_s - period) <= 3 * final.period_sigma_s + 1e-4 * period
    text = swing_text(loop, "bob", "px")
    assert "with turned plane taken, one more" in text or "with elliptical swing taken" in text
    assert "looks" in text and "% wider than the other" in text
    # Each alone is taken alone, and a swing square to the camera in its plane keeps
    # its sinusoid.
    for yaw_deg, across, taken in ((yaw, 0.0, "turned plane"),
                                   (0.0, 0.1, "elliptical swing"), (0.0, 0.0, None)):
        loop = fit_swing(*seen_swing(theta0, across, yaw_deg, distance, focal), 0.05)
        assert loop.accepted == taken, (yaw_deg, across, loop.delta_bic, loop.later)


def swing_angle(theta0: float, seconds: float = 20.0, fps: float = 30.0):
    """Times (s) and the angle (rad) of an undamped swing from rest at θ0."""
    t = np.arange(int(seconds * fps)) / fps
    sol = solve_ivp(lambda _, u: [u[1], -(G / L) * np.sin(u[0])], (0.0, t[-1]),
                    [theta0, 0.0], t_eval=t, rtol=1e-11, atol=1e-12, method="DOP853")
    return t, sol.y[0]


def test_the_command_fits_a_tracked_swing(tmp_path, capsys):
    from cranktrack.cli import main
    from cranktrack.files import write_csv_atomic, write_json_atomic

    # A run folder as `track` writes it, of a 0.4 rad swing drawn in pixels (0.5 px a
    # mm, the camera rolled by 30°), with no scale: the command fits along the swing,
    # whatever its direction, and reads the swing's angle off the arc of its path.
    t, theta = swing_angle(0.4)
    roll = np.radians(30)
    side, up = 0.5 * L * np.sin(theta), 0.5 * L * (1 - np.cos(theta))
    rng = np.random.default_rng(5)
    run = tmp_path / "run"
    run.mkdir()
    write_csv_atomic(run / "tracks.csv", pd.DataFrame({
        "frame": np.arange(t.size), "t_s": t,
        "bob_x_px": 400 + side * np.cos(roll) + up * np.sin(roll) + rng.normal(0, .1, t.size),
        "bob_y_px": 500 + side * np.sin(roll) - up * np.cos(roll) + rng.normal(0, .1, t.size),
        "bob_sigma_px": 0.1, "bob_ok": True, "bob_status": "ok"}))
    write_json_atomic(run / "run.json", {"source": {"width": 800, "height": 600}})
    assert main(["fit", str(run), "--model", "pendulum", "--marker", "bob",
                 "--length-mm", str(L)]) == 0
    out = capsys.readouterr().out
    period = float(out.split("period ")[1].split(" ")[0])
    # A 0.4 rad swing is 1 % slower than a small one, and g from it taken back by the
    # arc's angle (without it: 2 % low).
    assert period == pytest.approx(2 * np.pi * np.sqrt(L / G) * 1.0102, rel=2e-3)
    g = float(out.split("g = ")[1].split(" ")[0])
    assert g == pytest.approx(G / 1e3, rel=3e-3)
    assert "radius of its arc, 500 px" in out
    assert (run / "fit" / "swing.json").is_file()
    assert "## Swing of bob" in (run / "report.md").read_text()
    # The Python API: the same fit, and the first half of the track alone.
    import cranktrack as ct

    whole, half = ct.swing(run, "bob", L), ct.swing(run, "bob", L, end_s=10.0)
    assert whole.base.period_s == pytest.approx(period, abs=1e-5)
    assert half.samples == 301
    with pytest.raises(CranktrackError, match="comes before"):
        ct.swing(run, "bob", start_s=5.0, end_s=2.0)
    for args, says in ((["--model", "pendulum"], "needs --marker NAME"),
                       (["--model", "pendulum", "--marker", "bob", "--known", "L1_mm=3"],
                        "a pendulum takes --length-mm"),
                       (["--model", "flight", "--marker", "bob", "--length-mm", "3"],
                        "--length-mm is for --model pendulum"),
                       (["--length-mm", "3"], "are for --model flight, pendulum or rotation")):
        assert main(["fit", str(run), *args]) != 0
        assert says in capsys.readouterr().err
