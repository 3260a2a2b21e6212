# SPDX-License-Identifier: LGPL-2.1-or-later
"""Synthetic blades whose true surface is known exactly: the data of the demo, the instrument
simulator, the tests and the benchmarks (numpy only, like core)."""
