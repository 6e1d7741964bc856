"""The one exception type a person may see.

Library code raises :class:`CranktrackError` (or a subclass) for anything a
user can fix: a missing file, a video that is not a video, markers that are
not there, a bad option. Its message is one sentence that names the thing and,
where it helps, what to do. The CLI prints that sentence and exits non-zero;
any other exception is a bug.
"""


class CranktrackError(Exception):
    """A problem with the user's input, reported as one clear sentence.

    ``warnings`` are what the failed step had already noticed (a video cut
    short, a damaged stretch): often the real cause, so the CLI prints them
    before the sentence."""

    def __init__(self, message: str, warnings: tuple[str, ...] | list[str] = ()) -> None:
        super().__init__(message)
        self.warnings = tuple(warnings)


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C during a run. ``resumable`` says whether ``--resume`` can continue it
    (the tracker's state was saved), so the CLI only advertises what works."""

    def __init__(self, folder: str, resumable: bool) -> None:
        super().__init__(f"interrupted in {folder}")
        self.folder = folder
        self.resumable = resumable


class ViewerUnavailableError(CranktrackError):
    """The Rerun viewer could not be opened (no viewer executable, no display) after the
    recording at ``path`` was written in full: a warning for the CLI, not a failure."""

    def __init__(self, path: str) -> None:
        super().__init__(f"the Rerun viewer could not start here (no viewer or no display); "
                         f"{path} is written: open it with `rerun {path}` on a machine with a "
                         "display")
        self.path = path
