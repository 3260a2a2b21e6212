# SPDX-License-Identifier: LGPL-2.1-or-later
"""Tolerance inspection: the inspection plan (TOML), the zone best fit and the verdicts (issue 19).

Not to be confused with the *measurement* plan (:mod:`bladerecon.core.sections.plan`, the
``plan`` command), which says where to probe; the inspection plan says what is in tolerance.
"""
