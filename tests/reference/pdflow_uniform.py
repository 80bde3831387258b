#!/usr/bin/python3
"""PD-Flow's eval/uniformity/uniform.py (PU-GAN's uniformity), ported line by line as the oracle of
metrics/src/conventions.cpp's pdflow_uniformity_scores (tests/metrics/test_conventions.cpp runs
it on the files of pdflow_uniformity/uniformity.cpp, the original's C++ built as a test program).

Follows unknownue/pdflow at 78c4a67, eval/uniformity/uniform.py: analyze_uniform(idx_file,
radius_file, map_points_file). Changes, each marked "scanbench:" below:
  - sample_number is the disk count of the files (the original hard-codes 1000, its C++'s count);
  - the mapped points are kept in float64 (the original casts them to float32, which moves the
    nearest distances inside a disk in the fifth digit; its C++ here writes them with 17 digits);
  - np.float (removed in numpy 1.24: the original raises AttributeError when no disk has 5
    points) is float; the value is the 0.0 the original meant;
  - the regular expression is a raw string (the same pattern, without the DeprecationWarning).
sklearn's NearestNeighbors (algorithm='auto') as the original calls it.

usage: pdflow_uniform.py DIR  (DIR/eval/uniformity/pc_disk_idx.txt, pc_radius.txt,
pc_point2mesh_distance.txt); prints JSON {"uniformity": [5 values], "counts": [per line]}.
"""
import json
import math
import re
import sys

import numpy as np
from sklearn.neighbors import NearestNeighbors

UNIFORM_PRECENTAGE_NAMES = ['0.4%', '0.6%', '0.8%', '1.0%', '1.2%']
precentages = np.array([0.004, 0.006, 0.008, 0.010, 0.012])


def cal_nearest_distance(queries, pc, k=2):
    knn_search = NearestNeighbors(n_neighbors=k, algorithm='auto')
    knn_search.fit(pc)
    dis, knn_idx = knn_search.kneighbors(queries, return_distance=True)
    return dis[:, 1]


def analyze_uniform(idx_file, radius_file, map_points_file):

    points = np.loadtxt(map_points_file, ndmin=2)[:, 4:]  # scanbench: float64
    radius = np.loadtxt(radius_file)
    with open(idx_file) as f:
        lines = f.readlines()

    rad_number = radius.shape[0]
    sample_number = len(lines) // rad_number  # scanbench: the files' count (original: 1000)

    uniform_measure = np.zeros([rad_number, 1])

    densitys = np.zeros([rad_number, sample_number])

    expect_number = precentages * points.shape[0]
    expect_number = np.reshape(expect_number, [rad_number, 1])

    for j in range(rad_number):
        uniform_dis = []

        for i in range(sample_number):

            density, idx = lines[i * rad_number + j].split(':')
            densitys[j, i] = int(density)
            coverage = np.square(densitys[j, i] - expect_number[j]) / expect_number[j]

            num_points = re.findall(r"(\d+)", idx)  # scanbench: a raw string

            idx = list(map(int, num_points))
            if len(idx) < 5:
                continue

            idx = np.array(idx).astype(np.int32)
            map_point = points[idx]

            shortest_dis = cal_nearest_distance(map_point, map_point, 2)
            disk_area = math.pi * (radius[j] ** 2) / map_point.shape[0]
            expect_d = math.sqrt(2 * disk_area / 1.732)  # using hexagon

            dis = np.square(shortest_dis - expect_d) / expect_d
            dis_mean = np.nanmean(dis)
            uniform_dis.append(coverage * dis_mean)

        uniform_dis = np.array(uniform_dis).astype(np.float32)
        if len(uniform_dis) == 0:
            uniform_measure[j, 0] = np.array(0.0, dtype=float)  # scanbench: np.float
        else:
            uniform_measure[j, 0] = np.mean(uniform_dis)

    return uniform_measure


def main():
    base = sys.argv[1] + '/eval/uniformity/'
    u = analyze_uniform(base + 'pc_disk_idx.txt', base + 'pc_radius.txt',
                        base + 'pc_point2mesh_distance.txt')
    with open(base + 'pc_disk_idx.txt') as f:
        counts = [int(line.split(':')[0]) for line in f]
    print(json.dumps({"uniformity": [float(x) for x in u[:, 0]], "counts": counts}))


if __name__ == '__main__':
    main()
