#!/usr/bin/python3
"""ETH3D's multi-view evaluation at one tolerance, ported to numpy (float64, brute force) as the
oracle of metrics/src/conventions.cpp's eth3d_scores (tests/metrics/test_conventions.cpp runs it).

Follows ETH3D/multi-view-evaluation at 0daa4f4: src/accuracy.cc ClassifyPoint and
ComputeAccuracy, src/completeness.cc ComputeCompleteness, src/util.h CalcCellCoordinates,
src/main.cc's F1. The original keeps each scan's points in a spherical grid about the scanner and
visits the cells of the angular box around the tested point's direction that a beam could reach;
the port visits every scan point (the same set passes the beam test). The scans are given in the
global frame with their origins (the original transforms the point into each scan's frame; the
beam test is invariant to the rotation). Single tolerance: the early exit at tolerance index 0.

usage: eth3d_eval.py OUTPUT SCANS ORIGINS TOLERANCE VOXEL BEAM_START DIVERGENCE_DEG
  OUTPUT: one point per row; SCANS: rows "scan_index x y z"; ORIGINS: one origin per row.
prints JSON {"accuracy", "completeness", "f1", "accurate", "inaccurate", "unobserved"}.
"""
import json
import math
import sys

import numpy as np


def calc_cell_coordinates(p, voxel_size_inv, shift):
    """CalcCellCoordinates: truncation, minus one for a negative non-integer (a floor)."""
    return tuple(int(math.floor(c * voxel_size_inv + shift)) for c in p)


def classify_point(y, scan_rel, tol2, beam_start, tan_div):
    """ClassifyPoint for one scan, y relative to the scanner: (accurate, inaccurate_exists)."""
    ry = np.linalg.norm(y)
    beam_radius = beam_start + ry * tan_div
    ranges = np.linalg.norm(scan_rel, axis=1)
    dirs = scan_rel / ranges[:, None]
    along = dirs @ y
    inaccurate = False
    for j in range(len(scan_rel)):
        if along[j] < 0:
            continue
        closest = along[j] * dirs[j]
        if ((y - closest) ** 2).sum() <= beam_radius * beam_radius:
            if ((scan_rel[j] - y) ** 2).sum() <= tol2:
                return True, inaccurate
            if along[j] < ranges[j]:
                inaccurate = True
    return False, inaccurate


def main():
    output = np.loadtxt(sys.argv[1], ndmin=2)
    scans_rows = np.loadtxt(sys.argv[2], ndmin=2)
    origins = np.loadtxt(sys.argv[3], ndmin=2)
    tol, voxel, beam_start, div_deg = (float(a) for a in sys.argv[4:8])
    tol2 = tol * tol
    tan_div = math.tan(math.radians(div_deg))
    voxel_inv = 1.0 / voxel
    shifts = (0.0, 0.5)
    scans = [scans_rows[scans_rows[:, 0] == s, 1:] for s in range(len(origins))]

    # ComputeAccuracy
    cells = [{}, {}]
    counts = {"accurate": 0, "inaccurate": 0, "unobserved": 0}
    for x in output:
        accurate = False
        inaccurate = False
        for s, origin in enumerate(origins):
            if len(scans[s]) == 0:
                continue
            a, i = classify_point(x - origin, scans[s] - origin, tol2, beam_start, tan_div)
            inaccurate |= i
            if a:
                accurate = True
                break
        if not accurate and not inaccurate:
            counts["unobserved"] += 1
            continue
        counts["accurate" if accurate else "inaccurate"] += 1
        for g in range(2):
            key = calc_cell_coordinates(x, voxel_inv, shifts[g])
            c = cells[g].setdefault(key, [0, 0])
            c[0 if accurate else 1] += 1
    acc_sum, acc_n = 0.0, 0
    for g in range(2):
        for a, i in cells[g].values():
            acc_sum += np.float32(a) / np.float32(a + i)
            acc_n += 1
    accuracy = acc_sum / acc_n if acc_n else 0.0

    # ComputeCompleteness
    gt = np.concatenate([s for s in scans if len(s)], axis=0)
    ccells = [{}, {}]
    for p in gt:
        d2 = ((output - p) ** 2).sum(axis=1).min()
        complete = d2 <= tol2
        for g in range(2):
            c = ccells[g].setdefault(calc_cell_coordinates(p, voxel_inv, shifts[g]), [0, 0])
            c[0] += int(complete)
            c[1] += 1
    comp_sum = sum(c / n for g in range(2) for c, n in ccells[g].values())
    completeness = comp_sum / (len(ccells[0]) + len(ccells[1]))

    f1 = 0.0 if (accuracy <= 0 and completeness <= 0) else \
        2 * accuracy * completeness / (accuracy + completeness)
    print(json.dumps({"accuracy": float(accuracy), "completeness": float(completeness),
                      "f1": float(f1), **counts}))


if __name__ == "__main__":
    main()
