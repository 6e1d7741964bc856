"""The thesis's models: dynamics (chapter 3) and parametric maps (§2.2.2, §2.6)."""

import numpy as np
import pytest

from cranktrack.models.crank_slider import Incompatibility, incompatibility
from cranktrack.models.dynamics import CrankDynamics, classify
from cranktrack.models.maps import (
    CONTRACTION,
    CRANK_TOO_SHORT,
    FRAME_TOO_SHORT,
    OK,
    default_grid,
    rocking_angle_map,
)


@pytest.mark.parametrize("kw,eig,kind", [
    ({}, 0.97j, "centre"),  # Table 3.1, k_l = 1
    ({"k_l": 0.01}, 0.2, "saddle"),  # k_l = 0.01
    ({"L1": 10.0}, 0.707j, "centre"),  # L1 = 10
    ({"L1": 25.0}, 0.5, "saddle"),  # L1 = 25
])
def test_table_3_1(kw, eig, kind):
    d = CrankDynamics(**kw)
    ev = d.eigenvalues(np.pi)
    assert classify(ev) == kind
    # The thesis prints two or three digits.
    assert np.max(np.abs(np.abs(ev) - abs(eig))) < 0.006
    # And the stiffness ratio says which: SR > 1 ⇔ saddle at π.
    assert (d.stiffness_ratio > 1) == (kind == "saddle")


def test_stiffness_ratio_decides_the_type_at_pi():
    rng = np.random.default_rng(0)
    for _ in range(200):
        d = CrankDynamics(k_l=rng.uniform(0.01, 5), k_s=rng.uniform(0.01, 5),
                          L1=rng.uniform(1.5, 40))
        if abs(d.stiffness_ratio - 1) < 1e-6:
            continue
        kind = classify(d.eigenvalues(np.pi))
        assert kind == ("saddle" if d.stiffness_ratio > 1 else "centre")


def test_undamped_motion_conserves_energy_and_damped_loses_it():
    d = CrankDynamics(L1=2.0)
    t = np.linspace(0, 20, 2001)
    th, om = d.simulate(t, np.pi - 0.4, 0.3)
    e = d.energy(th, om)
    assert np.ptp(e) / e[0] < 1e-8
    dd = CrankDynamics(L1=2.0, k_d=0.5)
    t = np.linspace(0, 60, 3001)
    th, om = dd.simulate(t, np.pi - 0.4, 0.3)
    e = dd.energy(th, om)
    assert np.all(np.diff(e) <= 1e-12)
    # It settles in the well: at the stable equilibrium's energy (not zero — the
    # wire stays stretched there).
    well = min(dd.energy(q, 0.0) for q in dd.equilibria())
    assert e[-1] == pytest.approx(well, rel=1e-4) and e[-1] < 0.1 * e[0]


def test_small_oscillations_have_the_linearised_frequency():
    # Second method: the period of a small simulated oscillation vs 2π/|λ|.
    d = CrankDynamics(L1=10.0)
    lam = abs(d.eigenvalues(np.pi)[0].imag)
    t = np.linspace(0, 60, 60001)
    th, _ = d.simulate(t, np.pi + 1e-4, 0.0)
    x = th - np.pi
    crossings = t[1:][np.sign(x[1:]) != np.sign(x[:-1])]
    period = 2 * np.mean(np.diff(crossings))
    assert period == pytest.approx(2 * np.pi / lam, rel=1e-4)


def test_analytic_jacobian_matches_a_finite_difference():
    d = CrankDynamics(k_l=0.3, k_s=2.0, L1=3.0, theta0=2.0)
    th = np.linspace(0.3, 6.0, 50)
    h = 1e-6
    fd = (d.accel(th + h) - d.accel(th - h)) / (2 * h)
    np.testing.assert_allclose(d.daccel_dtheta(th), fd, rtol=1e-6, atol=1e-8)


def test_equilibria_are_roots_and_the_saddle_has_two_wells():
    d = CrankDynamics(k_l=0.01)  # SR = 5
    eq = d.equilibria()
    assert np.allclose(d.accel(eq), 0, atol=1e-10)
    kinds = [classify(d.eigenvalues(e)) for e in eq]
    assert kinds.count("saddle") == 1 and kinds.count("centre") == 2


def test_rocking_map_small_contraction_limit():
    # dθ = L3·dL3 / (L1·L2·sin θ): for a tiny contraction c, Δθ ≈ c·L3₀² / (L1·sin θ0).
    ratio, theta0 = np.array([1.5, 4.0, 20.0]), np.array([60.0, 100.0, 150.0])
    c = 1e-5
    m = rocking_angle_map(ratio, theta0, c)
    r, th = ratio[None, :], np.radians(theta0)[:, None]
    L3 = np.sqrt(r**2 + 1 - 2 * r * np.cos(th))
    np.testing.assert_allclose(m.rocking_deg, np.degrees(c * L3**2 / (r * np.sin(th))),
                               rtol=1e-3)


def test_rocking_map_masks_are_the_fig_2_5_incompatibilities():
    ratio, theta0 = default_grid(60)
    m = rocking_angle_map(ratio, theta0, CONTRACTION["rigid"])
    for i, t0 in enumerate(theta0):
        for j, r in enumerate(ratio):
            L3f = 0.95 * np.sqrt(r**2 + 1 - 2 * r * np.cos(np.radians(t0)))
            kind = incompatibility(r, 1.0, [L3f])[0]
            expected = {None: OK, Incompatibility.FRAME_TOO_SHORT: FRAME_TOO_SHORT,
                        Incompatibility.CRANK_TOO_SHORT: CRANK_TOO_SHORT}[kind]
            assert m.reason[i, j] == expected
    assert np.isnan(m.rocking_deg[m.reason != OK]).all()
    assert np.isfinite(m.rocking_deg[m.reason == OK]).all()


def test_sweep_cli_writes_csv_png_and_the_optimum(tmp_path, capsys):
    from cranktrack.cli import main

    assert main(["sweep", "rocking-angle", "--actuator", "muscle", "--n", "50",
                 "--out", str(tmp_path)]) == 0
    assert (tmp_path / "rocking_angle_muscle.csv").exists()
    assert (tmp_path / "rocking_angle_muscle.png").exists()
    assert "max rocking angle" in capsys.readouterr().out


def test_reproduction_rows_marked_exact_hold():
    from cranktrack.report.reproduction import rows

    exact = [r for r in rows() if r.exact]
    assert len(exact) == 7
    assert float(exact[6].ours.split()[2]) < 1e-12  # analytic vs trapezoid work, MJ/m³
    assert exact[0].ours == "30.85°" and exact[1].ours == "17.00 mm"
