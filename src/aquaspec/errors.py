"""Errors raised for bad input.

Every error names the offending value and says what is accepted, so a user
can fix the call without reading the source.
"""


class AquaspecError(ValueError):
    """Bad input to aquaspec: the message names the value and what is accepted."""


class DataRangeError(AquaspecError):
    """A wavelength range that the data do not cover."""


class GPUUnavailableError(RuntimeError):
    """No wgpu adapter could be created (message names what to install)."""
