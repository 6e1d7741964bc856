"""The SMA wire's heat transfer (thesis ch. 4) and its identification from a log (§4.4)."""

import json

import numpy as np
import pytest

from cranktrack.cli import main
from cranktrack.errors import CranktrackError
from cranktrack.models.heat import CurrentSteps, SMAWire, simulate_wire
from cranktrack.models.thermal_id import cp_derivative, identify
from cranktrack.synthetic.thermal_log import Instruments, standard_experiments, thermal_log

WIRE = SMAWire()
NOISY = Instruments(noise_C=0.1, noise_V=0.002, noise_A=0.001, noise_mm=0.001)


def test_constants_and_the_steady_temperature_of_eq_4_26():
    # m = ρ·π·d²/4·L and A_s = π·d·L for the Table 4.2 wire.
    assert WIRE.mass_kg == pytest.approx(6450 * np.pi * 0.25e-3**2 / 4 * 0.115, rel=1e-12)
    assert WIRE.surface_m2 == pytest.approx(np.pi * 0.25e-3 * 0.115, rel=1e-12)
    # With h = 625 W/m²K a 0.9 A step settles near 56 °C, just above A_s = 55 °C.
    assert WIRE.steady_temperature(0.9) == pytest.approx(56.0, abs=0.01)
    assert WIRE.current_for(float(WIRE.steady_temperature(0.9))) == pytest.approx(0.9)


def test_below_the_transformation_the_wire_is_a_first_order_lag():
    t = np.linspace(0, 1.5, 301)
    r = simulate_wire(WIRE, CurrentSteps((0.0,), (0.6,)), t)
    rise = WIRE.steady_temperature(0.6) - WIRE.T_amb_C
    exact = WIRE.T_amb_C + rise * (1 - np.exp(-t / WIRE.time_constant_s))
    np.testing.assert_allclose(r.T_C, exact, atol=1e-6)
    assert np.all(r.xi == 1.0) and np.all(r.latent_J == 0.0)


def test_energy_is_conserved_and_a_full_cycle_absorbs_then_releases_m_dh():
    t = np.linspace(0, 30, 3001)
    r = simulate_wire(WIRE, CurrentSteps((0.0, 10.0), (1.3, 0.0)), t)
    assert np.max(np.abs(r.energy_imbalance_J())) < 1e-6 * r.generated_J[-1]
    heated = np.searchsorted(t, 10.0)
    assert r.xi[heated] == pytest.approx(0.0, abs=1e-9)  # 1.3 A passes A_f (Fig. 4.5)
    assert r.latent_J[heated] == pytest.approx(WIRE.mass_kg * WIRE.dh_J_kg, rel=1e-9)
    assert r.xi[-1] == pytest.approx(1.0, abs=1e-9)  # back to martensite on cooling
    assert r.latent_J[-1] == pytest.approx(0.0, abs=1e-9)
    assert r.T_C[-1] == pytest.approx(WIRE.T_amb_C, abs=1e-6)
    # Hysteresis: on heating ξ is still 1 at 52 °C; on cooling it is already rising there.
    up, down = t < 10, t > 10
    assert np.interp(52.0, r.T_C[up], r.xi[up]) == 1.0
    assert np.interp(-52.0, -r.T_C[down], r.xi[down]) == pytest.approx(
        float(WIRE.xi_cooling(52.0)), abs=1e-6)


def test_latent_heat_slows_the_heating_through_the_transformation():
    t = np.linspace(0, 3, 3001)
    with_latent = simulate_wire(WIRE, CurrentSteps((0.0,), (1.3,)), t)
    without = simulate_wire(SMAWire(dh_J_kg=0.0), CurrentSteps((0.0,), (1.3,)), t)
    def reach(r, T):
        return t[np.argmax(r.T_C >= T)]
    assert reach(with_latent, 55.0) == pytest.approx(reach(without, 55.0), abs=2e-3)
    assert reach(with_latent, 70.0) > reach(without, 70.0) + 0.3


def test_resistance_and_h_are_identified_from_steady_states_even_with_a_slow_thermocouple():
    for ins in (NOISY, Instruments(**{**NOISY.__dict__, "thermocouple_tau_s": 1.0,
                                     "thermocouple_hz": 2.0})):
        result = identify(thermal_log(WIRE, standard_experiments(), ins), WIRE)
        assert result.R_ohm.value == pytest.approx(2.3, rel=1e-3)
        assert abs(result.R_ohm.value - 2.3) < 4 * result.R_ohm.sigma + 1e-4
        assert result.h_W_m2K.value == pytest.approx(625.0, rel=5e-3)
        assert result.T_amb_C == pytest.approx(23.0, abs=0.05)


def test_the_derivative_method_is_exact_in_the_limit_of_a_small_step():
    # Eq. 4.20 takes the initial heating rate as the rate throughout: exact as ΔT → 0.
    errors = []
    steps = (8.0, 2.0, 0.5)
    for below in steps:
        T0 = WIRE.As_C - below
        t = np.linspace(0, 0.2, 20001)
        r = simulate_wire(WIRE, CurrentSteps((0.0,), (1.0,)), t, T0_C=T0)
        dt = np.interp(WIRE.As_C, r.T_C, t)  # T rises monotonically
        errors.append(cp_derivative(WIRE, 1.0, T0, WIRE.As_C, dt) / WIRE.cp_J_kgK - 1)
    # The rate falls by h·A_s·ΔT over the step. Integrating m·c_p·dT/q(T) exactly gives
    # the relative error −ln(1 − x)/x − 1 with x = h·A_s·ΔT/q0: about x/2, → 0 with ΔT.
    for below, err in zip(steps, errors, strict=True):
        q0 = 1.0**2 * WIRE.R_ohm - WIRE.hA_W_K * (WIRE.As_C - below - WIRE.T_amb_C)
        x = WIRE.hA_W_K * below / q0
        assert err == pytest.approx(-np.log(1 - x) / x - 1, rel=1e-3)
    assert errors[0] > errors[1] > errors[2] and errors[-1] < 0.03


def test_a_lagging_thermocouple_biases_cp_and_dh_as_table_4_3_saw():
    fast = identify(thermal_log(WIRE, standard_experiments(), NOISY), WIRE)
    lag = Instruments(**{**NOISY.__dict__, "thermocouple_tau_s": 1.0, "thermocouple_hz": 2.0})
    slow = identify(thermal_log(WIRE, standard_experiments(), lag), WIRE)
    # Timed by the wire's own contraction, the lag does not matter; the methods' own
    # approximations leave c_p ~10 % low and Δh ~7 % low on this wire.
    for r in (fast, slow):
        assert r.cp_integral.value == pytest.approx(250.0, rel=0.15)
        assert r.dh.value == pytest.approx(30000.0, rel=0.1)
    # Timed by a fast thermocouple it is as good; by a slow one c_p comes out many times
    # too large and Δh meaningless, the scatter of Table 4.3.
    assert fast.cp_integral_thermocouple.value == pytest.approx(250.0, rel=0.15)
    assert slow.cp_integral_thermocouple.value > 4 * 250.0
    assert not slow.dh_thermocouple.value == pytest.approx(30000.0, rel=0.5)
    # What the table cannot say, in words: the slow thermocouple's c_p and (when it
    # comes out negative) its Δh; nothing about the thermocouple when it is fast.
    slow_notes = " ".join(slow.caveats())
    assert "c_p timed by the thermocouple is" in slow_notes
    assert ("Δh timed by the thermocouple is negative" in slow_notes) \
        == (slow.dh_thermocouple.value < 0)
    assert "thermocouple" not in " ".join(fast.caveats())


def test_thermal_id_command_and_its_errors(tmp_path, capsys):
    assert main(["synth", "thermal", "--out", str(tmp_path)]) == 0
    out = tmp_path / "id.json"
    assert main(["thermal-id", str(tmp_path / "thermal_log.csv"), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "R (V–I slope)" in printed and "Δh (eq. 4.25)" in printed
    assert json.loads(out.read_text())["R_ohm"]["value"] == pytest.approx(2.3, rel=1e-3)
    bad = tmp_path / "bad.csv"
    bad.write_text("t_s,current_A\n0,1\n")
    assert main(["thermal-id", str(bad)]) == 1
    assert "lacks the column(s)" in capsys.readouterr().err
    with pytest.raises(CranktrackError):
        SMAWire(As_C=80.0)


def test_a_frame_a_rounding_error_after_a_switch_is_fine():
    # np.arange(0, 10, 1e-3)[1400] is 1.4000000000000001: LSODA once refused it.
    grid = np.arange(0.0, 3.0, 1e-3)
    steps = CurrentSteps((0.2, 1.4), (1.1, 0.0))
    fast = simulate_wire(SMAWire(), steps, grid, fast=True)
    slow = simulate_wire(SMAWire(), steps, grid)
    np.testing.assert_allclose(fast.T_C, slow.T_C, atol=1e-4)


@pytest.mark.parametrize("times, amps", [((0.2, 1.4), (1.1, 0.0)),
                                         ((0.0, 2.0, 2.5, 4.0), (2.0, 0.0, 1.2, 0.3))])
def test_the_fast_integration_follows_the_adaptive_one(times, amps):
    # Switched off mid-transformation: on cooling, ξ rejoins its branch part-way and
    # the heat capacity jumps several-fold there, which a plain fixed step gets
    # wrong by 0.03 K (first order). Truth: scipy's adaptive Dormand–Prince, tight.
    grid = np.arange(0.0, 6.0, 5e-3)
    steps = CurrentSteps(times, amps)
    fast = simulate_wire(WIRE, steps, grid, fast=True)
    slow = simulate_wire(WIRE, steps, grid, rtol=1e-11)
    assert np.max(np.abs(fast.xi - slow.xi)) < 1e-5
    assert np.max(np.abs(fast.T_C - slow.T_C)) < 0.02
    np.testing.assert_allclose(fast.energy_imbalance_J(), 0.0, atol=1e-3)


@pytest.mark.parametrize("amps, on_s, off_s", [(1.3, 0.5, 3.0), (1.1, 0.2, 1.4)])
def test_the_fast_integration_follows_the_rig_built_from_its_parts(amps, on_s, off_s):
    # The adaptive solve above shares the fast path's right-hand side; this truth does
    # not: synthetic/sma_rig.py integrates the wire's enthalpy with its own hysteresis
    # (Heun, 0.5 ms) and imports nothing from models/. Measured: 0.11 K and ξ 5e-4.
    from cranktrack.synthetic.scenarios import SMAScenario
    from cranktrack.synthetic.sma_rig import current_step

    rig = SMAScenario().rig
    t, T, xi = rig.wire_history(current_step(amps, on_s, off_s), 6.0)
    # The same wire as the models describe it: its length on the bed, R scaled with it.
    length_m = 1e-3 * rig.wire_length_mm(rig.theta0_rad)
    wire = SMAWire(length_m=length_m, R_ohm=SMAWire().R_ohm * length_m / SMAWire().length_m)
    grid = np.arange(0.0, 6.0, 5e-3)
    fast = simulate_wire(wire, CurrentSteps((on_s, off_s), (amps, 0.0)), grid, fast=True)
    assert np.max(np.abs(fast.T_C - np.interp(grid, t, T))) < 0.2
    assert np.max(np.abs(fast.xi - np.interp(grid, t, xi))) < 1e-3
