"""Errors raised for bad input.

Every error names what is wrong and, where possible, what to do. The command line
maps :class:`InputError` to exit status 2 with the message on one line.
"""


class InputError(ValueError):
    """The input (file, shape, mesh or option) cannot be assessed as given."""


class FreeCADUnavailable(InputError):
    """FreeCAD's Python modules cannot be imported on this machine."""


class ReaderDied(InputError):
    """The process reading a file with OpenCascade ended (an exit or a signal) before it
    sent what it read: the message names the file, what the reader did and the likely
    cause (brep.reading.reader_process)."""
