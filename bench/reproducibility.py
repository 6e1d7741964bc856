"""The same real clips tracked again with an invisible change: how much the answer moves.

A ±1 DN pattern, fresh in every frame, is added to each clip's luminance (to every
channel of an RGB clip) before the tracker sees it: no one could tell the two
videos apart, and the codec's own noise is several times larger. The truth here is
that the answer should not change, so it needs no peer and no physics:

- *found*: how many frames the object is found in, as is and with each pattern. A
  count that changes shows a one-time decision (which blob, what size) that hangs
  on a pixel;
- *moved*: over the frames found both times, how far the fix moved (px), median and
  95th percentile, against the σ the tracker gave as is. A fix that moves by σ under
  a change this small has an error of at least that from noise alone;
- *jumps*: fixes that moved by more than 3 px (another place on the object, or
  another object);
- *learned*: what each run learned of the marker once (its radius, its hue window's
  centre, whether it is centred by its rim): the decisions behind such changes.

Last, the crank-slider's default markers (A green, B red, C blue) on OpenCV's clips
that hold no markers, as is and with each pattern: every find there is false.

The clips are those of ``bench/real_footage.py`` (Tracker's examples, a real
pendulum and yupi's rover wheel) and the objects at rest of ``bench/real_clips.py``
(OpenCV's vtest.avi, from its cache). Clips are not committed; give the same paths as to
``real_footage.py``, and without them it says so and exits 0:

    .venv/bin/python bench/reproducibility.py /path/to/OpenSourcePhysics/tracker \\
        --pendulum /path/to/juangomez177/Pendulum_Oscillatory_Motion [--seeds 3]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
import real_clips
import real_footage

from cranktrack.environment import versions_line
from cranktrack.tracker.markers import DEFAULT_MARKERS, parse_markers
from cranktrack.tracker.reproducibility import JUMP_PX, Patterned, reproducibility
from cranktrack.tracker.track import TrackResult, track
from cranktrack.tracker.video import open_frames
from cranktrack.warmup import compile_kernels


def compare(name: str, base: pd.DataFrame, others: list[pd.DataFrame]) -> str:
    """One line: found, moved and jumps of marker ``name`` over the patterned runs."""
    r = reproducibility(base, others, [name]).iloc[0]
    if not r.compared:
        found = [int(t[f"{name}_ok"].sum()) for t in others]
        return f"{name}: found in {r.found} frames as is, {found} with the pattern; none in both"
    return (f"{name}: found in {r.found} frames as is, {r.found_min}–{r.found_max} with the "
            f"pattern; moved median {r.moved_median_px:.3f}, 95 % {r.moved_p95_px:.3f} px "
            f"(σ median {r.sigma_median_px:.3f}); more than σ on an axis in "
            f"{100 * r.beyond_sigma:.0f} % of fixes; jumps over {JUMP_PX:g} px: "
            f"{r.jumps} of {r.compared}")


def learned(name: str, results: list[TrackResult]) -> str:
    """What each run learned of marker ``name`` once (its size, its hue window, whether
    it is centred by its rim): the one-time decisions a pattern can change."""
    radii = [r.learned[name]["radius_px"] for r in results]
    radii = [v for v in radii if v is not None]
    hues = [r.learned[name]["hue_deg"] for r in results]
    rims = [m.rim for r in results if r.state is not None
            for m in r.state.markers if m.spec.name == name]
    # Listed, not as a range: hues wrap round at 360°.
    size = f"radius {', '.join(f'{v:.1f}' for v in radii)} px; " if radii else ""
    return (f"    learned as is, then with each pattern: {size}hue "
            f"{', '.join(f'{v:.0f}' for v in hues)}°; centred by its rim in "
            f"{sum(bool(v) for v in rims)} of {len(results)}")


def run(label: str, video: Path, fps: float | None, markers: list[str], seeds: int) -> None:
    """Track ``video`` as is and with ``seeds`` patterns; print a line per marker."""
    specs = parse_markers(markers)
    t0 = time.perf_counter()
    results = [track(open_frames(video, fps), specs)]
    results += [track(Patterned(open_frames(video, fps), seed), specs) for seed in range(seeds)]
    base, others = results[0].tracks, [r.tracks for r in results[1:]]
    print(f"\n{label} ({len(base)} frames, {seeds} patterns, "
          f"{time.perf_counter() - t0:.0f} s)")
    for spec in specs:
        print("  " + compare(spec.name, base, others))
        print(learned(spec.name, results))


def run_no_markers(video: Path, seeds: int) -> None:
    """The crank-slider's default markers on a clip that has none: the share of frames
    each is "found" in, as is and with each pattern. Every find is false here, so this
    is how often the defaults take something for a marker, and whether that hangs on
    a pixel."""
    found = []
    for seed in [None, *range(seeds)]:
        source = open_frames(video, None)
        tab = track(source if seed is None else Patterned(source, seed), DEFAULT_MARKERS).tracks
        found.append({s.name: 100 * float(tab[f"{s.name}_ok"].mean()) for s in DEFAULT_MARKERS})
    # One run says little where a first find hangs on a pixel: the mean over all.
    print(f"  {video.name}: " + "; ".join(
        f"{s.name} {found[0][s.name]:.1f} % as is, "
        + "/".join(f"{f[s.name]:.0f}" for f in found[1:]) + " % with the patterns (mean "
        + f"{np.mean([f[s.name] for f in found]):.1f})"
        for s in DEFAULT_MARKERS))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    real_footage.add_clip_paths(ap)
    ap.add_argument("--seeds", type=int, default=3, help="patterns per clip (default 3)")
    args = ap.parse_args()
    print(f"libraries: {versions_line()}")
    vtest = real_clips.CACHE / "opencv-doc" / "vtest.avi"
    given = [p for p in (args.tracker, args.pendulum, args.rover)
             if p is not None and p.exists()]
    if not given and not vtest.exists():
        print("usage: bench/reproducibility.py [PATH-TO-OpenSourcePhysics/tracker] "
              "[--pendulum PATH-TO-juangomez177/Pendulum_Oscillatory_Motion] "
              "[--rover PATH-TO-yupidevs/yupi_examples]; no clip given and no vtest.avi "
              "cached by bench/real_clips.py, nothing measured")
        return
    compile_kernels()
    if args.tracker is not None and args.tracker.exists():
        for clip in real_footage.CLIPS:
            found = real_footage.footage(args.tracker, clip)
            if found is not None:
                run(f"{clip.trz} ({found.video.name})", found.video, found.fps, [clip.marker],
                    args.seeds)
    if args.pendulum is not None and args.pendulum.exists():
        name, marker = real_footage.PENDULUM.name, real_footage.PENDULUM.marker
        video = real_footage._extract(args.pendulum, name, folder="")
        if video is not None:
            run(name, video, None, [marker], args.seeds)
    if args.rover is not None and args.rover.exists():
        name, led, pivot = real_footage.ROVER
        video = real_footage._extract(args.rover, name, folder="resources/videos")
        if video is not None:
            run(name, video, None, [led, pivot], args.seeds)
    if vtest.exists():
        run("vtest.avi, objects at rest", vtest, None, list(real_clips.AT_REST), args.seeds)
    clips = [real_clips.CACHE / "opencv-doc" / n for n in ("box.mp4", "cup.mp4", "tree.avi",
                                                            "vtest.avi")]
    if any(c.exists() for c in clips):
        print("\nClips with no markers: the defaults A, B, C taken for a marker (% of frames)")
        for clip in clips:
            if clip.exists():
                run_no_markers(clip, args.seeds)


if __name__ == "__main__":
    main()
