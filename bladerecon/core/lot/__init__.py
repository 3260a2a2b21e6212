# SPDX-License-Identifier: LGPL-2.1-or-later
"""Production lots and blisks: lot statistics and capability (:mod:`.stats`), the manifest
of a lot (:mod:`.manifest`), the blisk's sectors and blade-to-blade position errors
(:mod:`.blisk`). numpy only."""
