#!/usr/bin/python3
"""PD-Flow's evaluator, ported line by line (float64) as the oracle of metrics/src/conventions.cpp's
pdflow_scores (tests/metrics/test_conventions.cpp runs it).

Follows unknownue/pdflow at 78c4a67, eval/evaluation.py: evaluation() scores
  CD  = point_cloud_utils.chamfer_distance(pred, gt)
  HD  = point_cloud_utils.hausdorff_distance(pred, gt)
  P2S = point2surface_distance(pred, gt, normals)
point-cloud-utils is not packaged in Debian: its chamfer_distance (the mean Euclidean nearest
distance pred->gt plus gt->pred, p_norm 2) and hausdorff_distance (the larger directed maximum,
squared_distances=False) are written out below with brute-force nearest neighbours.
point2surface_distance is the original's lines with sklearn's NearestNeighbors (ball tree), as
eval/evaluation.py calls it; the original loads float32 text files, this port keeps float64.

usage: pdflow_eval.py PRED GT GT_NORMALS  (text files, one point per row)
prints JSON {"CD", "HD", "P2S"}.
"""
import json
import sys

import numpy as np
from sklearn.neighbors import NearestNeighbors


def nearest_distances(src, tgt):
    """Euclidean distance of each src point to its nearest tgt point (brute force)."""
    out = np.empty(len(src))
    for s in range(0, len(src), 256):
        d = np.sqrt(((src[s:s + 256, None, :] - tgt[None, :, :]) ** 2).sum(-1))
        out[s:s + 256] = d.min(axis=1)
    return out


def chamfer_distance(x, y):
    """point_cloud_utils.chamfer_distance(x, y): mean(x->y) + mean(y->x), unsquared."""
    return nearest_distances(x, y).mean() + nearest_distances(y, x).mean()


def hausdorff_distance(x, y):
    """point_cloud_utils.hausdorff_distance(x, y): max of the two one-sided maxima."""
    return max(nearest_distances(x, y).max(), nearest_distances(y, x).max())


def point2surface_distance(pred, gt, n):
    """eval/evaluation.py point2surface_distance, the normals passed in rather than read."""
    nbrs = NearestNeighbors(n_neighbors=16, algorithm='ball_tree').fit(gt)
    _, indices = nbrs.kneighbors(pred)  # [N1, k]
    indices = indices.flatten()  # [N1 * k,]

    n = n[indices].reshape(-1, 16, 3)  # [N1, k, 3]

    p1 = pred.reshape(-1, 1, 3)  # [N1, 1, 3]
    p2 = gt[indices].reshape(-1, 16, 3)   # [N1, k, 3]

    numerator1 = np.sum(p1 * n, axis=-1)   # [N1, k]
    numerator2 = np.sum(p2 * n, axis=-1)   # [N1, k]

    numerator = np.abs(numerator1 - numerator2)   # [N1, k]
    denominator = np.sqrt(np.sum(n ** 2, axis=-1))  # [N1, k]

    p2s = numerator / denominator  # [N1, k]
    p2s = np.amin(p2s, axis=-1)  # [N1,]
    return np.average(p2s)


def main():
    pred, gt, normals = (np.loadtxt(f, dtype=np.float64, ndmin=2) for f in sys.argv[1:4])
    print(json.dumps({"CD": chamfer_distance(pred, gt), "HD": hausdorff_distance(pred, gt),
                      "P2S": point2surface_distance(pred, gt, normals)}))


if __name__ == "__main__":
    main()
