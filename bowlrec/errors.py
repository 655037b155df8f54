"""Every error bowlrec raises on purpose, in one tree.

:class:`BowlrecError` is the root. Its direct subclasses are categories that say what the
caller can do about the error; every concrete error derives from exactly one of them and, where
code outside bowlrec may already catch it by a builtin type, from that builtin too
(``except KeyError`` still catches :class:`RunNotFoundError`)::

    BowlrecError
    ├── InputError             the spec, file, request or argument is invalid: fix it
    │   ├── SpecError              (ValueError) a scene, ball or job spec is invalid
    │   │   ├── SceneInputError        (ValueError) a scene
    │   │   └── JobError               (ValueError) a batch job
    │   ├── SpecFileError          (ValueError) a file cannot be read as a spec
    │   ├── IllegalBallError       (ValueError) the ball breaks the selected rules
    │   ├── AimError               (ValueError) no release does what the aim asks for
    │   ├── BallRefError           (ValueError) a ball name or NAME@VERSION is malformed
    │   ├── IndexQueryError        (ValueError) a bad filter or sort column
    │   ├── UnknownFormatError     (ValueError) a file suffix names no output format
    │   ├── RunFileError           (ValueError) a file is not a bowlrec run file
    │   ├── ConfigError            (ValueError) the config file cannot be read
    │   ├── ArchiveError           (RuntimeError) the directory is not a usable archive
    │   └── MigrationError         (RuntimeError) the directory cannot be migrated
    ├── NotFoundError          no such run, ball or job: check the ID or name
    │   ├── RunNotFoundError       (KeyError)
    │   ├── BallNotFoundError      (KeyError)
    │   └── JobNotFoundError       (KeyError)
    ├── ConflictError          the request does not fit the state of what it names
    │   ├── SamplesRequiredError   (ValueError) a summary-only run has no path to draw
    │   ├── JobConflictError       (RuntimeError) the job's status does not allow it
    │   └── JobsLockedError        (RuntimeError) another live server runs the jobs
    ├── BusyError              try again later
    │   └── ServerBusyError        (RuntimeError) every recording slot is taken
    ├── DamagedError           stored data cannot be read: repair or restore it
    │   ├── RunDamagedError        (ValueError) a run's bytes fail their digest
    │   ├── SegmentError           (ValueError) a file is not a readable segment
    │   └── IndexUnreadableError   (RuntimeError) the index is missing or damaged
    ├── StorageError           a write failed (a full disk); nothing stored was lost
    │   └── ArchiveWriteError      (OSError)
    └── UnavailableError       something optional is not here: install or start it
        ├── MissingExtraError      (ImportError) an optional library is not installed
        └── ViewerUnavailableError (RuntimeError) no rerun viewer can be reached

How the front ends answer each category is written once in each: the exit codes of the
command line in :data:`bowlrec.cli._common.EXIT_CODES`, the HTTP status codes of the service in
:data:`bowlrec.service.app.STATUS_CODES`. Messages are one line (the field-named errors of a
spec: one line per problem). This module imports only the standard library.
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = [
    "AimError",
    "ArchiveError",
    "ArchiveWriteError",
    "BallNotFoundError",
    "BallRefError",
    "BowlrecError",
    "BusyError",
    "ConfigError",
    "ConflictError",
    "DamagedError",
    "IllegalBallError",
    "IndexQueryError",
    "IndexUnreadableError",
    "InputError",
    "JobConflictError",
    "JobError",
    "JobNotFoundError",
    "JobsLockedError",
    "MigrationError",
    "MissingExtraError",
    "NotFoundError",
    "RunDamagedError",
    "RunFileError",
    "RunNotFoundError",
    "SamplesRequiredError",
    "SceneInputError",
    "SegmentError",
    "ServerBusyError",
    "SpecError",
    "SpecFileError",
    "StorageError",
    "UnavailableError",
    "UnknownFormatError",
    "ViewerUnavailableError",
]


class BowlrecError(Exception):
    """An error bowlrec raises on purpose; catch this to catch them all."""


# -- categories --------------------------------------------------------------------------------


class InputError(BowlrecError):
    """The input is invalid (a spec, a file, a request, an argument); the message names what
    to change. Nothing was done."""


class NotFoundError(BowlrecError):
    """Nothing has the given ID or name."""

    def __str__(self) -> str:  # a KeyError quotes its message; show it plainly
        return str(self.args[0]) if len(self.args) == 1 else super().__str__()


class ConflictError(BowlrecError):
    """The request is valid but does not fit the current state of what it names (a run
    without samples, a job that already finished, an archive another server uses)."""


class BusyError(BowlrecError):
    """The request was refused for lack of capacity; the same request later may succeed."""


class DamagedError(BowlrecError):
    """Stored data cannot be read (bytes that fail their digest, an unreadable file); the
    message names what is damaged and how to repair it."""


class StorageError(BowlrecError):
    """Writing failed (a full disk, no permission); nothing already stored was lost."""


class UnavailableError(BowlrecError):
    """Something this needs is not here: an optional library that is not installed, a viewer
    that cannot be reached. Install or start it, or ask for another output."""


# -- input -------------------------------------------------------------------------------------


class SpecError(InputError, ValueError):
    """A scene, ball or job spec is invalid; one ``field: message`` line per problem."""


class SceneInputError(SpecError):
    """An invalid scene; the message names the offending fields (one per line)."""


class JobError(SpecError):
    """The job itself is invalid (a bad path, a value invalid on its own, a missing file)."""


class SpecFileError(InputError, ValueError):
    """A file that cannot be read as a spec (the message does not repeat the path)."""


class IllegalBallError(InputError, ValueError):
    """The ball breaks the selected rules and simulating it was not explicitly allowed.

    ``ball_name`` and ``rule_set`` name the ball and the rules; ``violations`` holds one line
    per broken rule, e.g. ``"rg_min 2.44 in (limit 2.46 in)"`` (the legality check,
    :mod:`bowlrec.bowling.legality`, writes them)."""

    def __init__(self, ball_name: str, rule_set: str, violations: Sequence[str]) -> None:
        super().__init__(
            f"ball {ball_name!r} is illegal under rule set '{rule_set}': "
            f"{'; '.join(violations)}; set allow_illegal to true to simulate it anyway"
        )
        self.ball_name, self.rule_set, self.violations = ball_name, rule_set, tuple(violations)

    def __reduce__(self) -> tuple[type[IllegalBallError], tuple[str, str, tuple[str, ...]]]:
        return type(self), (self.ball_name, self.rule_set, self.violations)


class AimError(InputError, ValueError):
    """No release in the allowed range makes the ball do what was asked (cross its target at
    the arrows, enter the pocket); the message names the closest it came."""


class BallRefError(InputError, ValueError):
    """A ball name or reference (``NAME`` or ``NAME@VERSION``) that is not well formed."""


class IndexQueryError(InputError, ValueError):
    """A bad query on the index (unknown column, bad comparison or value)."""


class UnknownFormatError(InputError, ValueError):
    """A file name whose suffix names no output format; the message lists the known ones."""


class RunFileError(InputError, ValueError):
    """A file is not a bowlrec run file, or of an unsupported format version."""


class ConfigError(InputError, ValueError):
    """The config file cannot be read (not valid TOML)."""


class ArchiveError(InputError, RuntimeError):
    """The directory is not a usable archive (not one, not empty, or of another format)."""


class MigrationError(InputError, RuntimeError):
    """The directory cannot be migrated (not an archive, or of an unknown format)."""


# -- not found ---------------------------------------------------------------------------------


class RunNotFoundError(NotFoundError, KeyError):
    """No run with that ID (or ID prefix) in the archive."""


class BallNotFoundError(NotFoundError, KeyError):
    """No library entry under that name (and version)."""


class JobNotFoundError(NotFoundError, KeyError):
    """No job with that ID."""


# -- conflict ----------------------------------------------------------------------------------


class SamplesRequiredError(ConflictError, ValueError):
    """A run recorded without samples (``options.record = 'summary'``) was given to something
    that draws or reports its path (a replay file, a plot, a bowler's report)."""


class JobConflictError(ConflictError, RuntimeError):
    """The job is not in a state that allows the request."""


class JobsLockedError(ConflictError, RuntimeError):
    """Another live server runs this archive's jobs."""


# -- busy --------------------------------------------------------------------------------------


class ServerBusyError(BusyError, RuntimeError):
    """Every recording slot is taken and enough requests wait for one."""


# -- damaged -----------------------------------------------------------------------------------


class RunDamagedError(DamagedError, ValueError):
    """A stored run's bytes do not match its digest (or cannot be read)."""

    def __init__(self, run_id: str, segment: str, reason: str) -> None:
        super().__init__(
            f"run {run_id} in segment {segment} is damaged ({reason}); "
            "`bowlrec runs repair` quarantines it and keeps the healthy runs"
        )
        self.run_id, self.segment, self.reason = run_id, segment, reason


class SegmentError(DamagedError, ValueError):
    """A file is not a readable segment of a supported format version."""


class IndexUnreadableError(DamagedError, RuntimeError):
    """The index file is missing, damaged or of another format (it can be rebuilt)."""


# -- storage -----------------------------------------------------------------------------------


class ArchiveWriteError(StorageError, OSError):
    """Writing to the archive failed (full disk, no permission); nothing stored was lost."""


# -- unavailable -------------------------------------------------------------------------------


class MissingExtraError(UnavailableError, ImportError):
    """An optional library is not installed; the message names the ``bowlrec[extra]`` that
    installs it."""


class ViewerUnavailableError(UnavailableError, RuntimeError):
    """No viewer can be reached: no display to spawn one, or nothing listens at the URL."""
