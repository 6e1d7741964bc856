"""Camera intrinsics and lens distortion from photos of a calibration board.

The OpenCV way, which users of OpenCV's and MATLAB's calibrators know:
detect the board's corners in each photo (chessboard corners refined to
sub-pixel, or ChArUco corners), then ``cv2.calibrateCamera`` for the camera
matrix and distortion (k1, k2, p1, p2, k3). The quality figures are the RMS
reprojection error overall and per view; a view whose error is far above
the others is flagged, since one bad detection skews the whole solution.

The fifth coefficient, k3, bends the frame's corners most. Photos that do not
need it still let it run off: drawn through a lens with no bend at all
(bench/tilted_bed.py), 15 photos gave k3 = −1.88, and the rig's angle measured
through that calibration was up to 0.11° off where holding k3 at 0 left 0.02°. So k3 is
kept only where the photos call for it (:data:`K3_BIC`), as OpenCV's own stereo
sample holds it at 0. The σ of each intrinsic (OpenCV's
``calibrateCameraExtended``) says when the photos do not fix the focal length.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from ..errors import CranktrackError
from .camera_model import distort_points, undistort_points

#: A view is flagged when its RMS exceeds this multiple of the median view's.
BAD_VIEW_FACTOR = 3.0
#: k3 is fitted only when freeing it lowers the BIC of the corners' reprojection by
#: more than this: the bar the closing loop sets an added term (loop/evidence.py).
#: Fitting it made the BIC worse on all of these: by 5.5 on OpenCV's 13 chessboard
#: photos (left*.jpg), 3.5 on its four ChArUco photos, 5.5-7.4 on 15 drawn photos.
K3_BIC = 20.0
#: What ``calibrate_camera`` may do with k3 (its ``k3``).
K3_CHOICES = ("auto", "free", "fixed")
#: The focal length's σ over this fraction of it: the photos do not fix the camera.
LOOSE_FOCAL = 0.02
#: Names of the intrinsics in the order of OpenCV's ``stdDeviationsIntrinsics``.
INTRINSIC_NAMES = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")


@dataclass(frozen=True)
class Board:
    """A calibration board.

    ``kind`` is ``"chessboard"`` (``size`` = inner corners, e.g. (9, 6)) or
    ``"charuco"`` (``size`` = squares, e.g. (5, 7), with ``marker_mm`` and an
    ArUco ``dictionary`` name such as ``"DICT_6X6_250"``). ``square_mm`` is the
    side of one square, mm.
    """

    kind: str
    size: tuple[int, int]
    square_mm: float
    marker_mm: float | None = None
    dictionary: str = "DICT_6X6_250"

    def __post_init__(self) -> None:
        if self.kind not in ("chessboard", "charuco"):
            raise CranktrackError(f"unknown board kind {self.kind!r}; use chessboard or charuco")
        if min(self.size) < 2 or not self.square_mm > 0:
            raise CranktrackError(f"board {self.size[0]}x{self.size[1]} with {self.square_mm} mm "
                                  "squares is not a usable board")
        if self.kind == "charuco":
            if not self.marker_mm or not 0 < self.marker_mm < self.square_mm:
                raise CranktrackError("a ChArUco board needs a marker size smaller than its "
                                      "squares (--marker-mm)")
            if not hasattr(cv2.aruco, self.dictionary):
                raise CranktrackError(f"unknown ArUco dictionary {self.dictionary!r}, e.g. "
                                      "DICT_6X6_250")

    def object_points(self) -> NDArray[np.float32]:
        """Chessboard inner corners in board mm (z = 0), row by row."""
        nx, ny = self.size
        grid = np.mgrid[0:nx, 0:ny].T.reshape(-1, 2).astype(np.float32)
        return np.hstack([grid * self.square_mm, np.zeros((nx * ny, 1), np.float32)])

    def _charuco(self) -> tuple[cv2.aruco.CharucoBoard, cv2.aruco.CharucoDetector]:
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        board = cv2.aruco.CharucoBoard(self.size, self.square_mm, self.marker_mm, d)
        return board, cv2.aruco.CharucoDetector(board)

    def detect(self, grey: NDArray[np.uint8]) -> tuple[NDArray, NDArray] | None:
        """Board points (mm, (n, 3)) and their image positions (px, (n, 1, 2)), or None."""
        if self.kind == "chessboard":
            found, corners = cv2.findChessboardCorners(
                grey, self.size, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
            if not found:
                return None
            corners = cv2.cornerSubPix(
                grey, corners, (11, 11), (-1, -1),
                (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 30, 0.01))
            return self.object_points(), corners.reshape(-1, 1, 2)
        board, detector = self._charuco()
        corners, ids, _, _ = detector.detectBoard(grey)
        if corners is None or len(corners) < 6:
            return None
        obj, img = board.matchImagePoints(corners, ids)
        return obj.reshape(-1, 3).astype(np.float32), img.reshape(-1, 1, 2).astype(np.float32)

    def to_dict(self) -> dict:
        d = {"kind": self.kind, "size": list(self.size), "square_mm": self.square_mm}
        if self.kind == "charuco":
            d |= {"marker_mm": self.marker_mm, "dictionary": self.dictionary}
        return d


@dataclass(frozen=True)
class CameraCalibration:
    """Intrinsics: ``camera_matrix`` (3×3, px), ``distortion`` (k1, k2, p1, p2, k3),
    ``image_size`` (width, height), RMS reprojection error overall and per view
    (px), the views used and those flagged as bad."""

    camera_matrix: NDArray[np.float64]
    distortion: NDArray[np.float64]
    image_size: tuple[int, int]
    rms_px: float
    per_view_rms_px: dict[str, float]
    bad_views: tuple[str, ...] = ()
    skipped: tuple[str, ...] = ()
    board: dict = field(default_factory=dict)
    flags: tuple[str, ...] = ()
    #: 1-σ of each intrinsic (:data:`INTRINSIC_NAMES`; px, or unitless for k, p), from
    #: the corners' scatter; 0 for one held fixed.
    sigma: dict[str, float] = field(default_factory=dict)
    #: How much freeing k3 lowered the BIC (NaN: not compared, k3 given by the user).
    k3_delta_bic: float = float("nan")
    warnings: tuple[str, ...] = ()

    @property
    def fx(self) -> float:
        return float(self.camera_matrix[0, 0])

    @property
    def fy(self) -> float:
        return float(self.camera_matrix[1, 1])

    def undistort_points(self, xy_px: NDArray) -> NDArray[np.float64]:
        """Image points (px, (n, 2)) to ideal pinhole points (px, same K), NaN kept."""
        return undistort_points(xy_px, self.camera_matrix, self.distortion)

    def distort_points(self, ideal_px: NDArray) -> NDArray[np.float64]:
        """Ideal pinhole points (px, (n, 2)) to where this lens puts them (px), NaN kept."""
        return distort_points(ideal_px, self.camera_matrix, self.distortion)

    def to_dict(self) -> dict:
        return {
            "camera_matrix": self.camera_matrix.tolist(),
            "distortion": self.distortion.ravel().tolist(),
            "image_size": list(self.image_size),
            "rms_px": self.rms_px,
            "per_view_rms_px": self.per_view_rms_px,
            "bad_views": list(self.bad_views),
            "skipped": list(self.skipped),
            "board": self.board,
            "flags": list(self.flags),
            "sigma": self.sigma,
            # null, not NaN, where it was not compared: the file stays strict JSON.
            "k3_delta_bic": self.k3_delta_bic if np.isfinite(self.k3_delta_bic) else None,
            "warnings": list(self.warnings),
        }

    @classmethod
    def from_dict(cls, d: dict) -> CameraCalibration:
        return cls(np.asarray(d["camera_matrix"], float), np.asarray(d["distortion"], float),
                   (int(d["image_size"][0]), int(d["image_size"][1])), float(d["rms_px"]),
                   dict(d.get("per_view_rms_px", {})), tuple(d.get("bad_views", ())),
                   tuple(d.get("skipped", ())), dict(d.get("board", {})),
                   tuple(d.get("flags", ())), dict(d.get("sigma", {})),
                   float(d.get("k3_delta_bic") if d.get("k3_delta_bic") is not None
                         else float("nan")), tuple(d.get("warnings", ())))


FLAG_NAMES = {"fix_aspect_ratio": cv2.CALIB_FIX_ASPECT_RATIO,
              "zero_tangent": cv2.CALIB_ZERO_TANGENT_DIST,
              "fix_k3": cv2.CALIB_FIX_K3}


def read_grey(path: str | os.PathLike) -> NDArray[np.uint8]:
    """A photo as 8-bit grey. Decoded from its bytes, so a file OpenCV cannot read is
    our one sentence, not OpenCV's warning on stderr as well."""
    path = Path(path)
    if not path.is_file():
        raise CranktrackError(f"{path} does not exist (or is not a file)")
    try:
        data = np.fromfile(path, np.uint8)
    except OSError as e:
        raise CranktrackError(f"{path} cannot be read ({e.strerror or e})") from None
    img = cv2.imdecode(data, cv2.IMREAD_GRAYSCALE) if data.size else None
    if img is None:
        raise CranktrackError(f"{path} is not an image OpenCV can read")
    return img


def calibrate_camera(images: list[str | os.PathLike], board: Board,
                     flags: tuple[str, ...] = (), k3: str = "auto") -> CameraCalibration:
    """Calibrate from photos of ``board``.

    Photos where the board is not found are skipped (and listed); at least
    three views are needed. ``flags`` are names from :data:`FLAG_NAMES`
    (e.g. ``("fix_aspect_ratio",)`` for fx = fy). ``k3``: "auto" fits the fifth
    distortion coefficient only where the photos call for it (:data:`K3_BIC`),
    "free" always (a wide-angle lens, or to match a calibration made so), "fixed"
    never (as the flag ``fix_k3``).

    Raises
    ------
    CranktrackError
        Unreadable images, mixed image sizes, or fewer than three usable views.
    """
    unknown = set(flags) - set(FLAG_NAMES)
    if unknown:
        raise CranktrackError(f"unknown calibration flag(s) {sorted(unknown)}; known: "
                              + ", ".join(FLAG_NAMES))
    _check_k3(k3)
    obj, img, names, skipped = [], [], [], []
    size = None
    for p in map(Path, images):
        grey = read_grey(p)
        this = (grey.shape[1], grey.shape[0])
        if size is None:
            size = this
        elif this != size:
            raise CranktrackError(f"{p} is {this[0]}x{this[1]} but the first photo was "
                                  f"{size[0]}x{size[1]}; calibrate one camera setting at a time")
        found = board.detect(grey)
        if found is None:
            skipped.append(p.name)
            continue
        obj.append(found[0])
        img.append(found[1])
        names.append(p.name)
    if len(obj) < 3:
        raise CranktrackError(
            f"the board was found in {len(obj)} of {len(images)} photo(s); at least 3 views are "
            f"needed (check --board {board.size[0]}x{board.size[1]} and the board kind)")
    return calibrate_corners(obj, img, size, names, board, flags, k3, tuple(skipped))


def calibrate_corners(obj: list[NDArray], img: list[NDArray], size: tuple[int, int],
                      names: list[str], board: Board, flags: tuple[str, ...] = (),
                      k3: str = "auto", skipped: tuple[str, ...] = ()) -> CameraCalibration:
    """The calibration of :func:`calibrate_camera` from the board's corners found in each
    view: ``obj`` their places on the board (mm, (n, 1, 3) float32 per view), ``img``
    where they were seen (px, (n, 1, 2) float32), the photos' ``size`` (width, height)
    and ``names``."""
    _check_k3(k3)
    if k3 == "fixed" and "fix_k3" not in flags:
        flags = (*flags, "fix_k3")
    flag_bits = 0
    for f in flags:
        flag_bits |= FLAG_NAMES[f]
    fit = _calibrate(obj, img, size, flag_bits)
    delta_bic = float("nan")
    if k3 == "auto" and "fix_k3" not in flags:
        held = _calibrate(obj, img, size, flag_bits | cv2.CALIB_FIX_K3)
        corners = sum(len(o) for o in obj)
        delta_bic = _bic(held[0], corners, 0) - _bic(fit[0], corners, 1)
        if delta_bic <= K3_BIC:
            fit, flags = held, (*flags, "fix_k3")
    rms, K, dist, rvecs, tvecs, sd = fit
    per_view = {}
    for name, o, i, r, t in zip(names, obj, img, rvecs, tvecs, strict=True):
        proj, _ = cv2.projectPoints(o, r, t, K, dist)
        d = proj.reshape(-1, 2) - i.reshape(-1, 2)
        per_view[name] = float(np.sqrt(np.mean(np.sum(d**2, axis=-1))))
    med = float(np.median(list(per_view.values())))
    bad = tuple(n for n, e in per_view.items() if e > BAD_VIEW_FACTOR * med)
    sigma = {n: float(v) for n, v in zip(INTRINSIC_NAMES, sd.ravel(), strict=False)}
    if "fix_aspect_ratio" in flags:
        # fx is fy times a held ratio: OpenCV gives fx's σ as 0, and the shared one as fy's.
        sigma["fx"] = sigma["fy"] * float(K[0, 0] / K[1, 1])
    warnings = ()
    if sigma["fx"] > LOOSE_FOCAL * K[0, 0]:
        warnings = (f"the focal length is not fixed by these {len(obj)} photos: fx "
                    f"{K[0, 0]:.1f} ± {sigma['fx']:.1f} px; take 10-20 photos with the board "
                    "tilted various ways and filling the frame's corners",)
    return CameraCalibration(K, dist.ravel(), size, float(rms), per_view, bad, skipped,
                             board.to_dict(), tuple(flags), sigma, delta_bic, warnings)


def _check_k3(k3: str) -> None:
    if k3 not in K3_CHOICES:
        raise CranktrackError(f"k3 must be one of {', '.join(K3_CHOICES)}, not {k3!r}")


def _calibrate(obj: list[NDArray], img: list[NDArray], size: tuple[int, int], flag_bits: int
               ) -> tuple[float, NDArray, NDArray, tuple, tuple, NDArray]:
    """OpenCV's calibration: RMS px, K, distortion, the views' poses, and σ of the
    intrinsics (:data:`INTRINSIC_NAMES`)."""
    rms, K, dist, rvecs, tvecs, sd, _, _ = cv2.calibrateCameraExtended(
        obj, img, size, None, None, flags=flag_bits)
    return float(rms), K, dist, rvecs, tvecs, sd


def _bic(rms_px: float, corners: int, extra: int) -> float:
    """BIC of a calibration's reprojection residuals (two per corner) up to a constant
    shared by the models compared, with ``extra`` parameters beyond the smaller one's."""
    n = 2 * corners
    return n * np.log(max(rms_px, 1e-12) ** 2 / 2.0) + extra * np.log(n)
