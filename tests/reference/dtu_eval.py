#!/usr/bin/python3
"""DTU's evaluation as DTUeval-python computes it, ported line by line as the oracle of
metrics/src/conventions.cpp's dtu_scores (tests/metrics/test_conventions.cpp runs it).

Follows jzhangbs/DTUeval-python at 45b4fec, eval.py, mode pcd, with sklearn's NearestNeighbors
as the original calls it. Left out, as scanbench's convention.dtu leaves them out: reading the
files, the shuffle (the caller passes the points in the order to thin them; eval.py shuffles
unseeded), the observation mask and the ground plane (every point counts), the visualisation.

usage: dtu_eval.py DATA STL DENSITY MAX_DIST  (text files, one point per row)
prints JSON {"mean_d2s", "mean_s2d", "over_all", "down_points"}.
"""
import json
import sys

import numpy as np
import sklearn.neighbors as skln


def main():
    data_pcd, stl = (np.loadtxt(f, dtype=np.float64, ndmin=2) for f in sys.argv[1:3])
    thresh, max_dist = float(sys.argv[3]), float(sys.argv[4])

    # downsample pcd
    nn_engine = skln.NearestNeighbors(n_neighbors=1, radius=thresh, algorithm='kd_tree', n_jobs=-1)
    nn_engine.fit(data_pcd)
    rnn_idxs = nn_engine.radius_neighbors(data_pcd, radius=thresh, return_distance=False)
    mask = np.ones(data_pcd.shape[0], dtype=np.bool_)
    for curr, idxs in enumerate(rnn_idxs):
        if mask[curr]:
            mask[idxs] = 0
            mask[curr] = 1
    data_down = data_pcd[mask]

    # masking data pcd: no observation mask, every point in
    data_in = data_down
    data_in_obs = data_down

    # compute data2stl
    nn_engine.fit(stl)
    dist_d2s, idx_d2s = nn_engine.kneighbors(data_in_obs, n_neighbors=1, return_distance=True)
    mean_d2s = dist_d2s[dist_d2s < max_dist].mean()

    # compute stl2data: no ground plane, every STL point above it
    stl_above = stl
    nn_engine.fit(data_in)
    dist_s2d, idx_s2d = nn_engine.kneighbors(stl_above, n_neighbors=1, return_distance=True)
    mean_s2d = dist_s2d[dist_s2d < max_dist].mean()

    over_all = (mean_d2s + mean_s2d) / 2
    print(json.dumps({"mean_d2s": mean_d2s, "mean_s2d": mean_s2d, "over_all": over_all,
                      "down_points": int(data_down.shape[0])}))


if __name__ == "__main__":
    main()
