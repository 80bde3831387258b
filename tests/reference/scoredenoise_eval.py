#!/usr/bin/python3
"""ScoreDenoise's evaluation scores, ported line by line to numpy (float64) as the oracle of
metrics/src/conventions.cpp (tests/metrics/test_conventions.cpp runs it).

Follows:
  luost26/score-denoise at bdf0eab, models/utils.py: normalize_sphere, normalize_pcl,
    chamfer_distance_unit_sphere, hausdorff_distance_unit_sphere,
    point_mesh_bidir_distance_single_unit_sphere;
  facebookresearch/pytorch3d v0.5.0 (4046677c, the version score-denoise pins):
    pytorch3d/loss/chamfer.py chamfer_distance (norm 2, point and batch reduction "mean"),
    pytorch3d/loss/point_mesh_distance.py point_mesh_face_distance,
    pytorch3d/csrc/utils/geometry_utils.h PointLine3DistanceForward, BarycentricCoords3Forward,
    IsInsideTriangle (area below 1e-5: not inside; 5e-3 from v0.6.2, commit ee71c7c4),
    PointTriangle3DistanceForward.
Brute force (every pair): for the small clouds of the tests.

usage: scoredenoise_eval.py GEN REF VERTS FACES MIN_TRIANGLE_AREA  (text files, one row each)
prints JSON {"cd_sph", "hd_sph", "p2f"}.
"""
import json
import sys

import numpy as np

K_EPSILON = 1e-8   # geometry_utils.h kEpsilon
V_EPSILON = 1e-8   # geometry_utils.h vEpsilon


def normalize_sphere(pc, radius=1.0):
    p_max = pc.max(axis=-2, keepdims=True)
    p_min = pc.min(axis=-2, keepdims=True)
    center = (p_max + p_min) / 2
    pc = pc - center
    scale = np.sqrt((pc ** 2).sum(axis=-1, keepdims=True)).max(axis=-2, keepdims=True) / radius
    pc = pc / scale
    return pc, center, scale


def normalize_pcl(pc, center, scale):
    return (pc - center) / scale


def knn1_sq(x, y):
    """knn_points(x, y, K=1) distances: squared distance of each x to its nearest y."""
    out = np.empty(len(x))
    for s in range(0, len(x), 512):
        d = ((x[s:s + 512, None, :] - y[None, :, :]) ** 2).sum(-1)
        out[s:s + 512] = d.min(axis=1)
    return out


def chamfer_distance(x, y):
    # chamfer.py: cham_x = mean over x of the squared nearest distance to y; cham_y likewise;
    # point_reduction "mean", batch of one.
    return knn1_sq(x, y).mean() + knn1_sq(y, x).mean()


def chamfer_distance_unit_sphere(gen, ref):
    ref, center, scale = normalize_sphere(ref)
    gen = normalize_pcl(gen, center, scale)
    return chamfer_distance(gen, ref)


def hausdorff_distance_unit_sphere(gen, ref):
    ref, center, scale = normalize_sphere(ref)
    gen = normalize_pcl(gen, center, scale)
    dists_ab = knn1_sq(ref, gen).max()
    dists_ba = knn1_sq(gen, ref).max()
    return max(dists_ab, dists_ba)


def dot(a, b):
    return (a * b).sum(-1)


def point_line_distance(p, v0, v1):
    # PointLine3DistanceForward, vectorised over broadcast rows.
    v1v0 = v1 - v0
    l2 = dot(v1v0, v1v0)
    degenerate = l2 <= K_EPSILON
    t = dot(v1v0, p - v0) / np.where(degenerate, 1.0, l2)
    tt = np.clip(t, 0.0, 1.0)
    p_proj = v0 + tt[..., None] * v1v0
    d = dot(p - p_proj, p - p_proj)
    return np.where(degenerate, dot(p - v1, p - v1), d)


def barycentric_coords(p, v0, v1, v2):
    # BarycentricCoords3Forward
    p0 = v1 - v0
    p1 = v2 - v0
    p2 = p - v0
    d00 = dot(p0, p0)
    d01 = dot(p0, p1)
    d11 = dot(p1, p1)
    d20 = dot(p2, p0)
    d21 = dot(p2, p1)
    denom = d00 * d11 - d01 * d01 + K_EPSILON
    w1 = (d11 * d20 - d01 * d21) / denom
    w2 = (d00 * d21 - d01 * d20) / denom
    w0 = 1.0 - w1 - w2
    return w0, w1, w2


def area_of_triangle(v0, v1, v2):
    # AreaOfTriangle: |(v1 - v0) x (v2 - v0)| / 2
    return np.linalg.norm(np.cross(v1 - v0, v2 - v0), axis=-1) / 2.0


def is_inside_triangle(p, v0, v1, v2, min_triangle_area):
    w0, w1, w2 = barycentric_coords(p, v0, v1, v2)
    inside = (0.0 <= w0) & (w0 <= 1.0) & (0.0 <= w1) & (w1 <= 1.0) & (0.0 <= w2) & (w2 <= 1.0)
    return inside & ~(area_of_triangle(v0, v1, v2) < min_triangle_area)


def point_triangle_distance(p, v0, v1, v2, min_triangle_area):
    # PointTriangle3DistanceForward
    normal = np.cross(v2 - v0, v1 - v0)
    norm_normal = np.linalg.norm(normal, axis=-1)
    normal = normal / (norm_normal + V_EPSILON)[..., None]
    t = dot(v0 - p, normal)
    p0 = p + t[..., None] * normal
    is_inside = is_inside_triangle(p0, v0, v1, v2, min_triangle_area)
    e01 = point_line_distance(p, v0, v1)
    e02 = point_line_distance(p, v0, v2)
    e12 = point_line_distance(p, v1, v2)
    dist = np.where(e01 > e02, e02, e01)
    dist = np.where(dist > e12, e12, dist)
    return np.where(is_inside & (norm_normal > K_EPSILON), t * t, dist)


def point_mesh_face_distance(verts, faces, points, min_triangle_area):
    tris = verts[faces]  # (T, 3, 3)
    v0, v1, v2 = tris[None, :, 0], tris[None, :, 1], tris[None, :, 2]
    point_to_face = np.empty(len(points))
    face_to_point = np.full(len(faces), np.inf)
    for s in range(0, len(points), 64):
        d = point_triangle_distance(points[s:s + 64, None, :], v0, v1, v2, min_triangle_area)
        point_to_face[s:s + 64] = d.min(axis=1)
        face_to_point = np.minimum(face_to_point, d.min(axis=0))
    # weights 1/P and 1/T, batch of one
    return point_to_face.mean() + face_to_point.mean()


def point_mesh_bidir_distance_single_unit_sphere(pcl, verts, faces, min_triangle_area):
    verts, center, scale = normalize_sphere(verts[None])
    verts = verts[0]
    pcl = normalize_pcl(pcl[None], center=center, scale=scale)[0]
    return point_mesh_face_distance(verts, faces, pcl, min_triangle_area)


def main():
    gen = np.loadtxt(sys.argv[1], ndmin=2)
    ref = np.loadtxt(sys.argv[2], ndmin=2)
    verts = np.loadtxt(sys.argv[3], ndmin=2)
    faces = np.loadtxt(sys.argv[4], ndmin=2, dtype=np.int64)
    area = float(sys.argv[5])
    print(json.dumps({
        "cd_sph": float(chamfer_distance_unit_sphere(gen, ref)),
        "hd_sph": float(hausdorff_distance_unit_sphere(gen, ref)),
        "p2f": float(point_mesh_bidir_distance_single_unit_sphere(gen, verts, faces, area)),
    }))


if __name__ == "__main__":
    main()
