"""What a run was made with: the versions of the libraries whose numbers decide a track.

The same code on the same clip can find a marker in a different number of frames
on another machine: on OpenCV's vtest.avi one commit of the tracker found a red
ring on a cone in 70.9 % of the frames it is in view on one day's machine and in
64.1 % on a fresh install the next (bench/README.md, stop 48). Decisions such as
which blob is taken first hang on small differences in the numbers these libraries
give (colour conversions, decoders, compiled arithmetic). ``run.json`` and the
benchmarks record their versions so that a figure can be traced to what made it.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

#: Distributions recorded, by the name they are installed under; the first of each
#: tuple that is installed is the one given (OpenCV has several wheels).
LIBRARIES: dict[str, tuple[str, ...]] = {
    "cranktrack": ("cranktrack",),
    "numpy": ("numpy",),
    "opencv": ("opencv-python-headless", "opencv-python", "opencv-contrib-python-headless",
               "opencv-contrib-python"),
    "av": ("av",),
    "numba": ("numba",),
    "pandas": ("pandas",),
    "scipy": ("scipy",),
}


def library_versions() -> dict[str, str]:
    """Installed versions of :data:`LIBRARIES` ("absent" where none is installed) and of
    the FFmpeg decoder library PyAV carries (``libavcodec``), read from the installed
    packages' metadata without importing them (but PyAV, for FFmpeg's)."""
    out: dict[str, str] = {}
    for key, names in LIBRARIES.items():
        out[key] = "absent"
        for name in names:
            try:
                out[key] = version(name)
                break
            except PackageNotFoundError:
                continue
    try:
        import av

        out["libavcodec"] = ".".join(str(v) for v in av.library_versions["libavcodec"])
    except (ImportError, KeyError):
        out["libavcodec"] = "absent"
    return out


def versions_line() -> str:
    """:func:`library_versions` on one line, ``name version`` pairs."""
    return ", ".join(f"{k} {v}" for k, v in library_versions().items())
