# SPDX-License-Identifier: LGPL-2.1-or-later
"""Live acquisition from a measuring instrument over a serial line (pyserial).

``reader``: journal-first reading with reconnection; ``simulator``: a controller that
plays a measurement of the sample blade on a pseudo-terminal. The protocol, the parser
and the calibration are pure Python/numpy in :mod:`bladerecon.core.io.instrument`.
"""
