"""Typed exceptions raised by the labcut API.

Every error a user can cause (bad parameters, broken meshes, missing files, an
unusable backend) is a :class:`LabcutError`; the CLI turns it into a one-line
message and exit status 2. Messages are single sentences that say what was wrong
and, where there is one, what to do.
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = ["BackendError", "CacheWarning", "LLVMVersionError", "LabcutError", "LabcutWarning", "MeshError", "OutputError", "ParameterError"]


class LabcutError(Exception):
    """Base class of every error labcut raises on purpose."""


class ParameterError(LabcutError, ValueError):
    """A parameter is out of range, not finite, or of the wrong kind.

    ``parameter`` is the library's name of the parameter the message begins with (``"seed"``,
    ``"time budget"``), or None; a front end that calls it otherwise (the CLI's ``--seed``)
    asks :meth:`renamed` instead of matching the message's text.
    """

    def __init__(self, message: str, *, parameter: str | None = None) -> None:
        super().__init__(message)
        self.parameter = parameter if parameter and message.startswith(parameter) else None

    def renamed(self, names: Mapping[str, str]) -> ParameterError:
        """This error with its parameter called by ``names[parameter]`` (itself when the
        parameter is unnamed or not in ``names``)."""
        option = names.get(self.parameter) if self.parameter else None
        if option is None:
            return self
        return ParameterError(option + str(self)[len(self.parameter):], parameter=option)


class MeshError(LabcutError):
    """A mesh cannot be read, or is broken in a way that cannot be repaired."""


class OutputError(LabcutError, OSError):
    """An output file could not be written (disk full, permissions, a writer's I/O error); the
    message names the user's path, and no partial file is left."""


class BackendError(LabcutError):
    """The Dr.Jit / Mitsuba backend cannot run on this machine."""


class LLVMVersionError(BackendError):
    """Dr.Jit's LLVM backend would abort: no libLLVM >= 17 is installed."""


class LabcutWarning(UserWarning):
    """Something that may make an answer wrong but is not an error: a mesh file that looked
    upside down or Y-up and was turned, an up axis the shape contradicts. The CLI prints
    these as ``warning:`` lines; they are also recorded in the result's JSON."""


class CacheWarning(LabcutWarning):
    """labcut's user cache could not be read or written, or a measurement was not kept in it: the
    work goes on (what the cache would have held is computed), so it says nothing about an
    answer, only about this run's time (:func:`labcut.fileio.cache_problem`)."""
