#pragma once
// Eigen decompositions of symmetric 3x3 matrices in double, a packet of matrices at a time, by
// cyclic Jacobi rotations (Golub and Van Loan, Matrix Computations, 4th ed., sec. 8.5.2-8.5.3;
// the rotation as in Numerical Recipes, 3rd ed., sec. 11.1). Private to the algorithms module.
//
// Written by hand because Eigen's SelfAdjointEigenSolver decomposes one matrix per call (a
// closed form whose eigenvectors need a residual check and an iterative fallback near repeated
// eigenvalues, or tridiagonal QR) and has no batched form; HEM's level 0 decomposes one
// covariance per point, and HEM ran 1.074x faster with this form (docs/performance.md). Jacobi's
// eigenvectors are accurate to the rounding of the matrix entries divided by the eigenvalue gap,
// with no case analysis.
//
// Each lane is one matrix through the same operations in the same order (no sum runs across
// lanes, no fused multiply-add asked for): a lane's result does not depend on its batch-mates, its
// place in the batch, the packet width (SCANBENCH_ISA) or the thread count. A rotation whose
// off-diagonal entry is negligible next to both diagonal entries (100 |a_pq| no longer changes
// them in double: Numerical Recipes' test) is skipped and the entry set to 0, so the sweeps a
// batch runs past a lane's convergence leave that lane exactly as it was.
#include <Eigen/Core>
#include <cstddef>

namespace scanbench::algorithms::detail {

/// Decomposes the n symmetric matrices in[0..n) (their upper triangles are read): values[i] the
/// eigenvalues of in[i], ascending; when `vectors` is not null, vectors[i] the unit eigenvectors
/// by column (column c of values[i](c); signs arbitrary but deterministic). Double packets of the
/// active ISA. A matrix still not diagonal after 50 sweeps (one with a NaN entry never is; no
/// finite matrix is known to need them) is decomposed by Eigen's iterative SelfAdjointEigenSolver
/// instead.
void sym_eigen3(const Eigen::Matrix3d* in, std::size_t n, Eigen::Vector3d* values,
                Eigen::Matrix3d* vectors);

}  // namespace scanbench::algorithms::detail
