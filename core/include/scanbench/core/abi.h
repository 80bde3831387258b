#pragma once
// The ABI version of scanbench's public interface: the installed headers and libraries
// (`cmake --install`, docs/plugins.md) that a plugin is compiled and linked against. It is the
// libraries' SOVERSION and the number a plugin reports through SCANBENCH_PLUGIN
// (scanbench/plugin.h); the plugin loader refuses a plugin built against another number.
//
// Bump it whenever a public type changes its layout or meaning (PointCloud, TriangleMesh,
// GaussianMixture, CovarianceMesh, PolygonFaces, StageData, RunContext, ParamSchema, the
// registries' entries, MetricInput, ClosestPoint, KdTree, NeighborGrid), or a public function
// its signature (2: CovarianceMesh's faces became a PolygonFaces; 3: NeighborGrid gained a
// layout, the exact-quotient cell rule and fine cells; 4: MetricInput gained step_input).
// cmake/Install.cmake reads the number from this line.
#define SCANBENCH_ABI_VERSION 4
