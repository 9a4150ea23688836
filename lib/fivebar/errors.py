"""The base of every error the library raises.

``except fivebar.FivebarError`` catches all of them.  Each library exception also keeps its
standard base (:class:`ValueError` for bad input, :class:`RuntimeError` for a computation that
failed), so ``except ValueError`` written before this base existed still works.

This module imports nothing of the linkage: the generic solvers (``newmark``, ``multiscale``)
derive their errors from it too.
"""

from __future__ import annotations

__all__ = ["ComputationError", "FivebarError", "InputError", "InputTypeError", "ParameterError"]


class FivebarError(Exception):
    """Base of every exception raised by fivebar."""


class InputError(FivebarError, ValueError):
    """A bad argument: the message names the value and what is allowed."""


class ParameterError(FivebarError, ValueError):
    """A parameter file or override holds a missing, unknown or invalid entry."""


class InputTypeError(FivebarError, TypeError):
    """An argument of the wrong type: the message names the type given and the one expected."""


class ComputationError(FivebarError, RuntimeError):
    """A computation could not produce its result (the message says which and why)."""
