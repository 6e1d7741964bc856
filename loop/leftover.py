"""What a residual no candidate explains looks like: its signature, in words and numbers.

When the library has nothing that brings the residual down to the noise, the
loop does not name an effect; it describes what is left so a person can
recognise the missing physics. Each description is a small least-squares fit
of the residual on one shape, scored by the share of the residual's variance
it takes:

- **periodic**: a sinusoid at the strongest frequency of the moving frames
  (amplitude, frequency, and whether it lives only while the drive moves),
  scored by what it adds to the lag below and put first when that is a fifth
  of the residual or more;
- **lag**: the residual as ``−τ·ω`` (a delay or lead of τ);
- **lag from a moment on**: ``−τ·ω`` only after some time mid-run, the best such
  time scanned over the moving frames (the drive paused, slipped or skipped there),
  kept when it takes a tenth of the residual more than a lag over the whole run;
- **offset after the start**: a step where the model starts to move (lost
  motion: play, a dead band, friction that must be overcome);
- **step at reversals**: a jump with the sign of ω (dry friction, play);
- **follows θ / image position / time**: a straight line in that series.

Angles in degrees, times in s, frequencies in Hz.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .evidence import model_motion


def _share(r: NDArray, columns: list[NDArray]) -> tuple[float, NDArray]:
    """Share of ``r``'s variance a least-squares fit on ``columns`` (plus a constant)
    takes, and the coefficients (constant last)."""
    X = np.column_stack([*columns, np.ones_like(r)])
    coef, *_ = np.linalg.lstsq(X, r, rcond=None)
    rest = r - X @ coef
    total = float(np.sum((r - r.mean()) ** 2))
    return (1.0 - float(rest @ rest) / total if total > 0 else 0.0), coef


def _strongest_frequency(t: NDArray, r: NDArray, moving: NDArray) -> float | None:
    """The frequency (Hz) of the largest periodogram peak over the frames ``moving``
    selects, at least 2.5 cycles long (fewer cannot be told from a bump) and below
    Nyquist; None without enough frames."""
    tm, rm = t[moving], r[moving]
    if tm.size < 16:
        return None
    span = float(tm[-1] - tm[0])
    dt = float(np.median(np.diff(tm)))
    freqs = np.linspace(2.5 / span, 0.45 / dt, 400) if span > 0 else np.array([])
    if freqs.size == 0 or freqs[0] >= freqs[-1]:
        return None
    rc = rm - rm.mean()
    w = 2 * np.pi * freqs[:, None] * tm[None, :]
    power = (np.cos(w) @ rc) ** 2 + (np.sin(w) @ rc) ** 2
    return float(freqs[int(np.argmax(power))])


#: What a lag that starts mid-run must take of the residual beyond a whole-run lag.
LATE_LAG_GAIN = 0.1


def _lag_from(t: NDArray, r: NDArray, omega: NDArray, moving: NDArray) -> dict | None:
    """The lag ``−τ·ω`` switched on at the moving frame that explains most of ``r``,
    leaving out the first and last three moving frames (there it is a whole-run lag or
    nothing); None with fewer than ten moving frames."""
    frames = np.flatnonzero(moving)
    if frames.size < 10:
        return None
    best = None
    for k in frames[3:-3]:
        after = (np.arange(r.size) >= k).astype(float)
        share, coef = _share(r, [omega * after])
        if best is None or share > best["share"]:
            best = {"kind": "lag from a moment on", "share": share, "lag_s": float(-coef[0]),
                    "from_s": float(t[k])}
    return best


def signature(t_s: NDArray, residual_deg: NDArray, model_deg: NDArray,
              context: dict[str, NDArray] | None = None) -> dict:
    """The leftover's signature: every shape tried, best first, and one sentence.

    ``residual_deg`` and ``model_deg`` are measured − model and the model's θ at
    ``t_s``; ``context`` adds series to test a straight-line dependence on (e.g.
    ``"B image row"``). Returns ``{"shapes": [...], "sentence": str}``; each shape has
    ``kind``, ``share`` (of the residual's variance, 0–1) and its figures.
    """
    t = np.asarray(t_s, float)
    r = np.asarray(residual_deg, float)
    model = np.asarray(model_deg, float)
    omega, moving = model_motion(model, t)  # deg/s
    shapes: list[dict] = []

    # A ripple lives while the drive moves and often rides on a lag (the base fit
    # shifts to meet it halfway): it is sought and fitted beside the −τ·ω term, and
    # its share is what it adds to that term's.
    lag_share, lag_coef = _share(r, [omega]) if moving.any() else (0.0, np.zeros(2))
    periodic = []
    for frames in (moving, np.ones_like(moving)):  # locked to the drive, or always there
        f = _strongest_frequency(t, r - lag_coef[0] * omega, frames)
        if f is None:
            continue
        c, s = np.cos(2 * np.pi * f * t) * frames, np.sin(2 * np.pi * f * t) * frames
        total, coef = _share(r, [c, s, omega])
        periodic.append({"kind": "periodic", "share": total - lag_share, "hz": f,
                         "amplitude_deg": float(np.hypot(coef[0], coef[1])),
                         "while_moving_only": bool(frames is moving)})
    if periodic:
        shapes.append(max(periodic, key=lambda p: p["share"]))
    if moving.any():
        share, coef = _share(r, [omega])
        shapes.append({"kind": "lag", "share": share, "lag_s": float(-coef[0])})
        late = _lag_from(t, r, omega, moving)
        if late is not None and late["share"] >= share + LATE_LAG_GAIN:
            shapes.append(late)
        first = int(np.argmax(moving))
        after_start = (np.arange(r.size) >= first).astype(float)
        share, coef = _share(r, [after_start])
        shapes.append({"kind": "offset after the start", "share": share,
                       "offset_deg": float(coef[0]), "from_s": float(t[first])})
        sign = np.sign(omega)
        if np.unique(sign[moving]).size > 1:  # reversals exist
            share, coef = _share(r, [sign])
            shapes.append({"kind": "step at reversals", "share": share,
                           "step_deg": float(2 * coef[0])})
    for name, x in {"theta": model, "time": t, **(context or {})}.items():
        x = np.asarray(x, float)
        ok = np.isfinite(x)
        if ok.sum() > 3 and np.std(x[ok]) > 0:
            share, coef = _share(r[ok], [x[ok]])
            shapes.append({"kind": f"follows {name}", "share": share, "slope": float(coef[0])})
    # A ripple that takes a fifth of the residual beyond the lag is the news.
    shapes.sort(key=lambda s: -(s["share"] + (1.0 if s["kind"] == "periodic"
                                               and s["share"] >= 0.2 else 0.0)))
    sentence = _sentence(shapes[0]) if shapes else ""
    if (len(shapes) > 1 and shapes[1]["share"] >= 0.8 * shapes[0]["share"]
            and shapes[1]["kind"] != "lag"):
        sentence += "; or, about as well, " + _sentence(shapes[1])  # say it is ambiguous
    return {"shapes": shapes, "sentence": sentence}


def _sentence(s: dict) -> str:
    """One plain sentence for a shape."""
    pct = f"{100 * s['share']:.0f} % of it"
    if s["kind"] == "periodic":
        where = ("only while the drive moves, so locked to the drive (a spool or gear that "
                 "turns off-centre, a ripple in the drive's speed)"
                 if s["while_moving_only"] else "also while the drive stands still, so not "
                 "from the drive (a vibration of the rig or the camera)")
        return (f"a ripple of ±{s['amplitude_deg']:.3g}° at {s['hz']:.3g} Hz ({pct}), "
                f"{where}")
    if s["kind"] == "lag":
        way = "behind" if s["lag_s"] > 0 else "ahead of"
        return (f"the crank runs {abs(s['lag_s']) * 1e3:.3g} ms {way} the model ({pct}): a "
                "lag such as a slow heat or a compliant link, or a clock offset")
    if s["kind"] == "lag from a moment on":
        way = "behind" if s["lag_s"] > 0 else "ahead of"
        return (f"the crank follows the model until {s['from_s']:.3g} s, then runs "
                f"{abs(s['lag_s']) * 1e3:.3g} ms {way} it ({pct}): the drive paused, "
                "slipped or skipped there")
    if s["kind"] == "offset after the start":
        return (f"the crank stays {abs(s['offset_deg']):.3g}° off the model from the moment "
                f"the drive starts ({pct}): lost motion such as play, a dead band or friction "
                "that must be overcome before the crank moves")
    if s["kind"] == "step at reversals":
        return (f"a step of {abs(s['step_deg']):.3g}° each time the crank reverses ({pct}): "
                "dry friction or play")
    name = s["kind"].removeprefix("follows ")
    return (f"it follows {name} in a straight line ({pct}, slope {s['slope']:.3g}° per unit)"
            + (": a camera effect or a calibration that bends the image"
               if "image" in name or name == "theta" else ""))
