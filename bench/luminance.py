"""An experiment not adopted: adding the luminance of clean edge sectors to the disc fit.

The tracker's disc fit reads only chroma, so grey links under a marker's edge
cannot bias it; but most of the information about the edge is in the
luminance (the Cramér–Rao bound for all three channels is 1.7–2.4× lower than
for chroma alone; ``bench/accuracy.py``). This script tries to use that
information where it is safe:

1. split the edge into ``--sectors`` angular sectors about the tracker's centre;
2. call a sector clean when the luminance of its ring just outside the marker
   (r + 1.5 … r + 5 px) and of its band just inside (r − 4 … r − 2 px) scatters
   no more than twice the median sector's (at least 1.5 DN), and when neither
   neighbour is dirty (a link's side edge crosses the marker edge at an angle,
   so the ring sees it a few degrees from where the edge has it underneath);
3. fit the luminance of the clean sectors' pixels (r − 5 … r + 5 px) with a
   blurred-disc edge of its own radius and blur, a background level per sector
   and a marker level per sector; σ from the residual and the Jacobian;
4. combine its centre with the chroma fit's by inverse variance.

It prints, per render and marker, the per-axis RMS error against
``truth.csv`` and the mean reported σ of the chroma fit, the luminance fit
and their combination, with the bound for the noisy lossless render.

    .venv/bin/python bench/luminance.py [--sectors 24]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
from scipy.special import erf

sys.path.insert(0, str(Path(__file__).resolve().parent))
from accuracy import CASES, case_scene

from cranktrack.synthetic.bounds import marker_crb_px
from cranktrack.tracker.track import _patch, refine, track
from cranktrack.tracker.video import open_frames


def sector_fit(patch: np.ndarray, x0: int, y0: int, shape: tuple[float, ...], sectors: int
               ) -> tuple[np.ndarray, np.ndarray, int] | None:
    """Luminance edge fit over clean sectors: (centre px, its 2×2 covariance, sectors used)."""
    cx, cy, r, s = shape[0], shape[1], shape[2], max(shape[3], 0.2)
    lum = patch.astype(np.float64).sum(axis=2) / math.sqrt(3.0)  # noise σ as one channel's
    yy, xx = np.mgrid[0 : lum.shape[0], 0 : lum.shape[1]]
    X, Y = xx + float(x0), yy + float(y0)
    d = np.hypot(X - cx, Y - cy)
    sec = ((np.arctan2(Y - cy, X - cx) + np.pi) / (2 * np.pi) * sectors).astype(int) % sectors
    ring = (d >= r + 1.5) & (d <= r + 5)
    inner = (d >= r - 4) & (d <= r - 2)
    ring_sd = np.array([lum[ring & (sec == k)].std() for k in range(sectors)])
    inner_sd = np.array([lum[inner & (sec == k)].std() for k in range(sectors)])
    dirty = ((ring_sd > max(2 * np.median(ring_sd), 1.5))
             | (inner_sd > max(2 * np.median(inner_sd), 1.5)))
    clean = ~(dirty | np.roll(dirty, 1) | np.roll(dirty, -1))
    if clean.sum() < 4:
        return None
    use = (d >= r - 5) & (d <= r + 5) & clean[sec]
    kept = np.flatnonzero(clean)
    slot = np.full(sectors, -1)
    slot[kept] = np.arange(kept.size)
    xs, ys, ls, k = X[use], Y[use], lum[use], slot[sec[use]]
    m = kept.size
    q = np.concatenate([[cx, cy, r, s],
                        [lum[ring & (sec == j)].mean() for j in kept],
                        [lum[inner & (sec == j)].mean() for j in kept]])
    rows = np.arange(ls.size)
    for _ in range(12):
        dx, dy = xs - q[0], ys - q[1]
        dd = np.hypot(dx, dy) + 1e-9
        z = (q[2] - dd) / q[3]
        phi = 0.5 * (1 + erf(z / math.sqrt(2)))
        g = np.exp(-0.5 * z * z) / math.sqrt(2 * math.pi) / q[3]
        back, mark = q[4 + k], q[4 + m + k]
        amp = mark - back
        J = np.zeros((ls.size, q.size))
        J[:, 0], J[:, 1] = amp * g * dx / dd, amp * g * dy / dd
        J[:, 2], J[:, 3] = amp * g, -amp * g * z
        J[rows, 4 + k] = 1 - phi
        J[rows, 4 + m + k] = phi
        res = ls - (back + amp * phi)
        JtJ = J.T @ J
        step = np.linalg.solve(JtJ + 1e-9 * np.eye(q.size), J.T @ res)
        q += step
        q[3] = max(q[3], 0.05)
        if abs(step[0]) < 1e-4 and abs(step[1]) < 1e-4:
            break
    cov = np.linalg.inv(JtJ) * float(res @ res) / (ls.size - q.size)
    return q[:2], cov[:2, :2], int(m)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sectors", type=int, default=24)
    args = parser.parse_args()
    for label, settings in CASES.items():
        files, truth, meta, radius = case_scene(label, settings)
        tracks = track(open_frames(files.video)).tracks.set_index("frame")
        got: dict[tuple[str, str], list] = {}
        used: dict[str, list] = {m: [] for m in "ABC"}
        for frame in open_frames(files.video).frames():
            row, true_row = tracks.loc[frame.index], truth.iloc[frame.index]
            for m in "ABC":
                if not np.isfinite(row[f"{m}_x_px"]):
                    continue
                c, _ = refine(frame, (row[f"{m}_x_px"], row[f"{m}_y_px"]), radius)
                lum = sector_fit(*_patch(frame, c.x, c.y, radius + 9), c.params, args.sectors)
                if not c.ok or lum is None:
                    continue
                true = np.array([true_row[f"{m}_x_px"], true_row[f"{m}_y_px"]])
                centre_c, cov_c = np.array([c.x, c.y]), np.eye(2) * c.sigma**2
                centre_l, cov_l, n_used = lum
                w_c, w_l = np.linalg.inv(cov_c), np.linalg.inv(cov_l)
                cov_b = np.linalg.inv(w_c + w_l)
                both = cov_b @ (w_c @ centre_c + w_l @ centre_l)
                for name, centre, cov in (("chroma fit", centre_c, cov_c),
                                          ("luminance sectors", centre_l, cov_l),
                                          ("combined", both, cov_b)):
                    got.setdefault((name, m), []).append(
                        (*(centre - true), math.sqrt(np.trace(cov) / 2)))
                used[m].append(n_used)
        print(f"\n== {label}: {len(truth)} frames; clean sectors used (of {args.sectors}): "
              + ", ".join(f"{m} {np.mean(used[m]):.1f}" for m in "ABC"))
        print(f"{'method':18s} " + " ".join(f"{m + ' err / σ':>16s}" for m in "ABC")
              + "   (per-axis RMS error and mean σ, px)")
        for name in ("chroma fit", "luminance sectors", "combined"):
            cells = []
            for m in "ABC":
                e = np.array(got[(name, m)])
                cells.append(f"{np.sqrt(np.mean(e[:, :2] ** 2)):.4f} / {e[:, 2].mean():.4f}")
            print(f"{name:18s} " + " ".join(f"{c:>16s}" for c in cells))
        if settings.noise_dn and settings.lossless:
            pts = {m: np.array([truth[f"{m}_x_px"][0], truth[f"{m}_y_px"][0]]) for m in "ABC"}
            bounds = [marker_crb_px(pts, m, settings.size, meta["camera"]["px_per_mm"],
                                    settings.noise_dn)[0] for m in "ABC"]
            print(f"{'CRB, full RGB':18s} " + " ".join(f"{b:16.4f}" for b in bounds))


if __name__ == "__main__":
    main()
