"""Typed exceptions raised by the labcut API.

Every error a user can cause (bad parameters, broken meshes, missing files, an
unusable backend) is a :class:`LabcutError`; the CLI turns it into a one-line
message and exit status 2. Messages are single sentences that say what was wrong
and, where there is one, what to do.
"""

from __future__ import annotations


class LabcutError(Exception):
    """Base class of every error labcut raises on purpose."""


class ParameterError(LabcutError, ValueError):
    """A parameter is out of range, not finite, or of the wrong kind."""


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
