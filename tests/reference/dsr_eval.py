#!/usr/bin/python3
"""The dsr-benchmark's point scores, ported line by line to numpy (float64) as the oracle of
metrics/src/conventions.cpp's dsr_scores (tests/metrics/test_conventions.cpp runs it).

Follows raphaelsulzer/dsr-benchmark at ffbc98a, dsrb/eval.py: MeshEvaluator.distance_p2p,
eval_pointcloud (Chamfer = 0.5 (completeness + accuracy), Hausdorff, Normal Consistency) and
eval (lengths divided by diag / 10**2, diag of the target points' bounding box). scipy's
cKDTree.query (Euclidean distance and index of the nearest target) is replaced by brute force.

usage: dsr_eval.py PRED PRED_NORMALS TGT TGT_NORMALS  (text files, one row each)
prints JSON of the scores as eval() stores them.
"""
import json
import sys

import numpy as np


def knn1(points_src, points_tgt):
    """cKDTree(points_tgt).query(points_src): distance to and index of the nearest target."""
    dist = np.empty(len(points_src))
    idx = np.empty(len(points_src), dtype=np.int64)
    for s in range(0, len(points_src), 256):
        d = np.sqrt(((points_src[s:s + 256, None, :] - points_tgt[None, :, :]) ** 2).sum(-1))
        idx[s:s + 256] = d.argmin(axis=1)
        dist[s:s + 256] = d.min(axis=1)
    return dist, idx


def distance_p2p(points_src, normals_src, points_tgt, normals_tgt):
    dist, idx = knn1(points_src, points_tgt)
    if normals_src is not None and normals_tgt is not None:
        normals_src = normals_src / np.linalg.norm(normals_src, axis=-1, keepdims=True)
        normals_tgt = normals_tgt / np.linalg.norm(normals_tgt, axis=-1, keepdims=True)
        normals_dot_product = (normals_tgt[idx] * normals_src).sum(axis=-1)
        normals_dot_product = np.abs(normals_dot_product)
    else:
        normals_dot_product = np.array([np.nan] * points_src.shape[0], dtype=np.float32)
    return dist, normals_dot_product


def eval_pointcloud(pointcloud, pointcloud_tgt, normals=None, normals_tgt=None):
    completeness, completeness_normals = distance_p2p(pointcloud_tgt, normals_tgt, pointcloud, normals)
    completeness_max = completeness.max()
    completeness_mean = completeness.mean()
    completeness_normals = completeness_normals.mean()
    accuracy, accuracy_normals = distance_p2p(pointcloud, normals, pointcloud_tgt, normals_tgt)
    accuracy_max = accuracy.max()
    accuracy_mean = accuracy.mean()
    accuracy_normals = accuracy_normals.mean()
    normals_correctness = 0.5 * completeness_normals + 0.5 * accuracy_normals
    chamfer = 0.5 * (completeness_mean + accuracy_mean)
    hausdorff = max(completeness_max, accuracy_max)
    return {
        'HD_gt->r': completeness_max,
        'HD_r->gt': accuracy_max,
        'Hausdorff': hausdorff,
        'CD_gt->r': completeness_mean,
        'CD_r->gt': accuracy_mean,
        'Chamfer': chamfer,
        'Normal Consistency': normals_correctness,
    }


def main():
    pred = np.loadtxt(sys.argv[1], ndmin=2)
    pred_n = np.loadtxt(sys.argv[2], ndmin=2)
    tgt = np.loadtxt(sys.argv[3], ndmin=2)
    tgt_n = np.loadtxt(sys.argv[4], ndmin=2)
    d = eval_pointcloud(pred, tgt, pred_n, tgt_n)
    # eval(): scale_with_diag
    ppmin = tgt.min(axis=0)
    ppmax = tgt.max(axis=0)
    diag = np.linalg.norm(ppmax - ppmin, ord=2, axis=0)
    scale = diag / 10**2
    out = {k: float(d[k] / scale) for k in ['Chamfer', 'CD_gt->r', 'CD_r->gt', 'Hausdorff',
                                              'HD_gt->r', 'HD_r->gt']}
    out['Normal Consistency'] = float(d['Normal Consistency'])
    print(json.dumps(out))


if __name__ == "__main__":
    main()
