# SPDX-License-Identifier: LGPL-2.1-or-later
"""Stages 3-4, sections -> curves -> surface: section curves, common parameterisation and
skinning, angle pairing, non-grid rows, local bicubic patches, surface fairing, T-splines."""
