"""`cranktrack check`: the same clip tracked again with invisible patterns, and how far
each marker's fixes move against their σ. The expected figures are built by hand
(tables shifted by known amounts) or drawn (a disc on a plain ground)."""

import numpy as np
import pandas as pd

from cranktrack.tracker.reproducibility import Patterned, reproducibility
from cranktrack.tracker.video import open_frames


def _table(x: list[float], ok: list[bool], sigma: float = 0.1) -> pd.DataFrame:
    return pd.DataFrame({"m_x_px": x, "m_y_px": [50.0] * len(x), "m_sigma_px": sigma,
                         "m_ok": ok})


def test_moves_found_counts_and_jumps_are_those_built_in():
    base = _table([10.0, 11.0, 12.0, 13.0], [True, True, True, True])
    # Moved by 0.05 px (within σ), 0.3 px (beyond), and 5 px (a jump); one frame lost.
    other = _table([10.05, 11.3, 17.0, 13.0], [True, True, True, False])
    r = reproducibility(base, [other], ["m"]).iloc[0]
    assert (r.found, r.found_min, r.found_max, r.compared, r.jumps) == (4, 3, 3, 3, 1)
    assert np.isclose(r.moved_median_px, 0.3) and np.isclose(r.beyond_sigma, 2 / 3)
    assert np.isclose(r.sigma_median_px, 0.1)
    from cranktrack.report.console import reproducibility_text

    said = reproducibility_text(reproducibility(base, [other], ["m"]), "clip.mp4", 4, 1)
    assert "1 fix moved more than 3 px" in said, said
    assert "found in 3 frames with the patterns against 4 as is: which blob" in said, said
    # 95 of 100 frames is a few borderline views, not another blob.
    many = _table([10.0] * 100, [True] * 100)
    fewer = _table([10.0] * 100, [True] * 95 + [False] * 5)
    said = reproducibility_text(reproducibility(many, [fewer], ["m"]), "clip.mp4", 100, 1)
    assert "a few borderline frames" in said and "which blob" not in said, said


def test_a_pattern_is_invisible_and_repeatable(tmp_path):
    import cv2

    image = np.full((40, 60, 3), 128, np.uint8)
    for k in range(3):
        cv2.imwrite(str(tmp_path / f"{k:03d}.png"), image)
    plain = [f.rgb.astype(int) for f in open_frames(tmp_path, 10.0).frames()]
    once = [f.rgb.astype(int) for f in Patterned(open_frames(tmp_path, 10.0), 7).frames()]
    again = [f.rgb.astype(int) for f in Patterned(open_frames(tmp_path, 10.0), 7).frames()]
    for a, b, c in zip(plain, once, again, strict=True):
        assert np.abs(b - a).max() == 1 and (b != a).mean() > 0.5 and (b == c).all()


def test_check_prints_a_line_per_marker_and_writes_the_table(tmp_path, capsys):
    import cv2

    from cranktrack.cli import main

    yy, xx = np.mgrid[0:120, 0:160]
    frames = tmp_path / "frames"
    frames.mkdir()
    for k in range(12):  # a red disc moving 2 px a frame on grey
        cover = np.clip(6.5 - np.hypot(xx - (50.3 + 2 * k), yy - 60.6), 0, 1)[..., None]
        image = 120 + cover * (np.array([200, 30, 40]) - 120)
        image += np.random.default_rng(k).normal(0, 2.0, image.shape)
        image = np.clip(image.round(), 0, 255).astype(np.uint8)
        cv2.imwrite(str(frames / f"{k:03d}.png"), cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    out = tmp_path / "new" / "check.csv"  # a folder not made yet is made
    assert main(["check", str(frames), "--fps", "10", "--marker", "b=red", "--patterns", "2",
                 "--out", str(out)]) == 0
    text = capsys.readouterr().out
    table = pd.read_csv(out)
    assert list(table["marker"]) == ["b"] and table.loc[0, "found"] == 12
    assert table.loc[0, "jumps"] == 0 and table.loc[0, "moved_median_px"] < 0.1
    assert "b: the same frames" in text and "2 invisible" in text
    # A clip that is not there: one sentence, no traceback.
    assert main(["check", str(tmp_path / "none.mp4")]) == 1
    assert "does not exist" in capsys.readouterr().err
    # A table that cannot be written is said before the clip is tracked.
    assert main(["check", str(frames), "--fps", "10", "--marker", "b=red",
                 "--out", str(out / "under_a_file.csv")]) == 1
    captured = capsys.readouterr()
    assert "is not a folder" in captured.err and "b " not in captured.out
