#pragma once
/// \file symmetric_eigen.hpp
/// Eigen-decomposition of a small symmetric matrix by cyclic Jacobi rotations, for ICP's 6 x 6 normal
/// equations. Jacobi converges to machine precision in a handful of sweeps and takes microseconds at
/// this size; Eigen's SelfAdjointEigenSolver does the same job but its 6 x 6 instantiation
/// (tridiagonalization, Householder sequences) cost every translation unit that runs ICP seconds of
/// compile time.

#include <cmath>
#include <limits>

#include <Eigen/Core>

namespace binpick {
namespace registration_detail {

/// Eigenvalues of the symmetric matrix `A` in ascending order and their unit eigenvectors as the
/// columns of `vectors` (signs arbitrary). Only the upper triangle and the diagonal of `A` are read.
/// Non-finite input (or entries whose squares overflow, |a| > 1e150) gives NaN output.
template <int N>
void symmetric_eigen(const Eigen::Matrix<double, N, N>& A, Eigen::Matrix<double, N, 1>& values,
                     Eigen::Matrix<double, N, N>& vectors) {
  double a[N][N], v[N][N];
  double scale = 0;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) {
      a[i][j] = i <= j ? A(i, j) : A(j, i);
      v[i][j] = i == j ? 1.0 : 0.0;
      scale += a[i][j] * a[i][j];
    }
  if (!std::isfinite(scale)) {
    values.setConstant(std::numeric_limits<double>::quiet_NaN());
    vectors.setConstant(std::numeric_limits<double>::quiet_NaN());
    return;
  }
  for (int sweep = 0; sweep < 64; ++sweep) {
    double off = 0;
    for (int p = 0; p < N; ++p)
      for (int q = p + 1; q < N; ++q) off += a[p][q] * a[p][q];
    if (!(off > 1e-32 * scale)) break;  // diagonal to machine precision
    for (int p = 0; p < N; ++p)
      for (int q = p + 1; q < N; ++q) {
        const double apq = a[p][q];
        if (apq == 0) continue;
        // The rotation that zeroes a[p][q]: tan φ = t, the smaller root of t² + 2θt − 1 = 0.
        const double theta = (a[q][q] - a[p][p]) / (2 * apq);
        const double t = std::abs(theta) > 1e150 ? 1 / (2 * theta)
                                                 : (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1));
        const double c = 1 / std::sqrt(t * t + 1), s = t * c;
        for (int k = 0; k < N; ++k) {  // A J
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < N; ++k) {  // Jᵀ (A J)
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < N; ++k) {  // V J
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
  }
  // Ascending order (selection sort: N is small).
  int order[N];
  for (int i = 0; i < N; ++i) order[i] = i;
  for (int i = 0; i < N; ++i) {
    int m = i;
    for (int j = i + 1; j < N; ++j)
      if (a[order[j]][order[j]] < a[order[m]][order[m]]) m = j;
    const int tmp = order[i];
    order[i] = order[m];
    order[m] = tmp;
  }
  for (int i = 0; i < N; ++i) {
    values(i) = a[order[i]][order[i]];
    for (int k = 0; k < N; ++k) vectors(k, i) = v[k][order[i]];
  }
}

}  // namespace registration_detail
}  // namespace binpick
