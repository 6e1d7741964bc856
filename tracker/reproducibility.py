"""How much a track's answer moves under a change no one could see.

The clip is tracked again with a ±1 DN pattern added to every frame, fresh in each
(:class:`Patterned`): the two videos cannot be told apart, and the codec's own
noise is several times larger. The truth is that the answer should not change, so
it needs no peer and no physics. A marker found in another number of frames shows
a one-time decision (which blob, what size) that hangs on a pixel; a fix that moves
by more than its σ has an error of at least that from noise alone
(:func:`reproducibility`). On yupi's rover clip the red pivot's fixes moved 0.66 px
(median) under such a pattern, against a σ of 0.04 px: each run settled another
size for it (bench/README.md, stop 48).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Sequence

import numpy as np
import pandas as pd

from .video import Frame, FrameSource

#: How far (px) a fix may move under the pattern before it counts as a jump: another
#: place on the object, or another object.
JUMP_PX = 3.0


@dataclasses.dataclass
class Patterned:
    """A :class:`.video.FrameSource` whose frames carry a ±1 DN pattern, fresh in each
    frame (drawn from ``seed`` and the frame's index, so a run is repeatable)."""

    source: FrameSource
    seed: int

    def __getattr__(self, name: str):
        return getattr(self.source, name)

    def frames(self, prefetch: int = 0) -> Iterator[Frame]:
        for f in self.source.frames(prefetch):
            rng = np.random.default_rng((self.seed, f.index))
            pixels = f.pixels.astype(np.int16)
            # Luminance only where the decoder's planes are kept: Y is the top 2/3.
            rows = pixels.shape[0] * 2 // 3 if f.layout == "i420" else pixels.shape[0]
            pixels[:rows] += rng.integers(-1, 2, size=pixels[:rows].shape, dtype=np.int16)
            yield dataclasses.replace(f, pixels=np.clip(pixels, 0, 255).astype(np.uint8))


def reproducibility(base: pd.DataFrame, others: list[pd.DataFrame],
                    names: Sequence[str]) -> pd.DataFrame:
    """Per marker named in ``names``, a tracks table ``base`` (as is) against the same clip
    tracked with patterns (``others``): ``found`` (frames, as is), ``found_min`` and
    ``found_max`` (with the patterns), over the fixes found both times ``moved_median_px``
    and ``moved_p95_px`` (2-D), ``sigma_median_px`` (the per-axis σ given as is),
    ``beyond_sigma`` (share of those fixes moved by more than σ on an axis), ``jumps``
    (moved more than :data:`JUMP_PX`) and ``compared`` (fixes found both times)."""
    rows = []
    for name in names:
        ok = base[f"{name}_ok"].to_numpy(bool)
        xy = base[[f"{name}_x_px", f"{name}_y_px"]].to_numpy(float)
        sigma = base[f"{name}_sigma_px"].to_numpy(float)
        found, moved, beyond = [], [], []
        for tab in others:
            ok2 = tab[f"{name}_ok"].to_numpy(bool)
            found.append(int(ok2.sum()))
            both = ok & ok2
            delta = xy[both] - tab[[f"{name}_x_px", f"{name}_y_px"]].to_numpy(float)[both]
            moved.append(np.hypot(delta[:, 0], delta[:, 1]))
            # σ is per axis: the larger of the two axes' moves against it.
            beyond.append(np.abs(delta).max(axis=1) > sigma[both])
        d = np.concatenate(moved) if moved else np.array([])
        out = np.concatenate(beyond) if beyond else np.array([], bool)
        rows.append({
            "marker": name, "found": int(ok.sum()),
            "found_min": min(found) if found else int(ok.sum()),
            "found_max": max(found) if found else int(ok.sum()),
            "moved_median_px": float(np.median(d)) if len(d) else float("nan"),
            "moved_p95_px": float(np.percentile(d, 95)) if len(d) else float("nan"),
            "sigma_median_px": float(np.median(sigma[ok])) if ok.any() else float("nan"),
            "beyond_sigma": float(out.mean()) if len(out) else float("nan"),
            "jumps": int((d > JUMP_PX).sum()), "compared": len(d)})
    return pd.DataFrame(rows)
