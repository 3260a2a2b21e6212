# SPDX-License-Identifier: LGPL-2.1-or-later
"""The one exception type for errors a user can cause (bad file, too few points, ...)."""
from __future__ import annotations

__all__ = ["BladeReconError"]


class BladeReconError(Exception):
    """A user-facing error: the message says what was wrong, where, and what to do.

    The CLI prints ``str(err)`` on one line and exits with status 2; the GUI shows the
    same text in a message box. Never raise it with a numpy traceback text inside.
    """
