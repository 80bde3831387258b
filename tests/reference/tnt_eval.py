#!/usr/bin/python3
"""The Tanks and Temples evaluation on Debian's python3-open3d, as the oracle of
metrics/src/conventions.cpp's tnt_scores (tests/metrics/test_conventions.cpp runs it).

Follows isl-org/TanksAndTemples at 3c2c212, python_toolbox/evaluation/evaluation.py:
EvaluateHisto's steps on the two clouds (Open3D's own voxel_down_sample and
compute_point_cloud_distance) and get_f1_score_histo2's precision, recall and F-score, line by
line. Left out, as scanbench's convention.tnt leaves them out: the alignment transform (the
output is in the ground truth's frame), the crop volume (the ground truth is the whole shape),
the normal estimation and the coloured PLY files (they do not enter the scores).

usage: tnt_eval.py SOURCE TARGET TAU VOXEL  (text files, one point per row)
prints JSON {"precision", "recall", "fscore", "source_points", "target_points"}.
"""
import json
import sys

import numpy as np
import open3d as o3d


def get_f1_score_histo2(threshold, distance1, distance2):
    """The scores of get_f1_score_histo2 (its histograms are not compared)."""
    if len(distance1) and len(distance2):
        recall = float(sum(d < threshold for d in distance2)) / float(len(distance2))
        precision = float(sum(d < threshold for d in distance1)) / float(len(distance1))
        fscore = 2 * recall * precision / (recall + precision)
    else:
        precision = 0
        recall = 0
        fscore = 0
    return precision, recall, fscore


def main():
    source_xyz, target_xyz = (np.loadtxt(f, dtype=np.float64, ndmin=2) for f in sys.argv[1:3])
    threshold, voxel_size = float(sys.argv[3]), float(sys.argv[4])
    source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(source_xyz))
    target = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(target_xyz))
    # EvaluateHisto, without the transform and the crop:
    s = source.voxel_down_sample(voxel_size)
    t = target.voxel_down_sample(voxel_size)
    distance1 = s.compute_point_cloud_distance(t)
    distance2 = t.compute_point_cloud_distance(s)
    precision, recall, fscore = get_f1_score_histo2(threshold, distance1, distance2)
    print(json.dumps({"precision": precision, "recall": recall, "fscore": fscore,
                      "source_points": len(s.points), "target_points": len(t.points)}))


if __name__ == "__main__":
    main()
