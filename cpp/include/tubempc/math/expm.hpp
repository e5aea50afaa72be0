/// @file expm.hpp
/// Matrix exponential of fixed-size matrices (Pade scaling and squaring, Higham 2005) and the exact
/// zero-order-hold discretisation of an affine system through one exponential of the augmented
/// matrix (docs/model.md, "Linearisation and discretisation"). With fixed sizes neither allocates,
/// so both run inside the MPC's allocation-free step; Eigen::Dynamic sizes (which allocate) serve
/// models of any size set up once (mpc::LtiModel). Pure math: used by dynamics (the proximity model's
/// discretisation) and mpc.
#pragma once

#include <Eigen/Dense>
#include <cmath>

namespace tubempc::math {

/// e^M for a fixed-size square M by the scaling-and-squaring method with diagonal Pade
/// approximants of degree 3, 5, 7, 9 or 13 (N. J. Higham, "The scaling and squaring method for the
/// matrix exponential revisited", SIAM J. Matrix Anal. Appl. 26(4), 2005, Algorithm 2.3): the lowest
/// degree whose backward-error bound theta_m covers ||M||_1 is used; otherwise M is scaled by
/// 2^-s so that ||M/2^s||_1 <= theta_13 and the degree-13 result is squared s times.
/// @tparam N the matrix size (fixed, > 0, or Eigen::Dynamic).
/// @param M the matrix (dimensionless, e.g. A dt).
/// @param E receives e^M.
/// @return false if M or the result is not finite (E is then unspecified).
template <int N>
bool expm(const Eigen::Matrix<double, N, N>& M, Eigen::Matrix<double, N, N>& E) {
  static_assert(N > 0 || N == Eigen::Dynamic, "expm needs a square matrix");
  using Mat = Eigen::Matrix<double, N, N>;
  if (M.rows() != M.cols() || M.rows() == 0 || !M.allFinite()) return false;
  const double norm1 = M.cwiseAbs().colwise().sum().maxCoeff();
  const Mat I = Mat::Identity(M.rows(), M.cols());
  Mat U;
  Mat V;
  int squarings = 0;
  if (norm1 <= 1.495585217958292e-2) {
    const Mat M2 = M * M;
    U = M * (M2 + 60.0 * I);
    V = 12.0 * M2 + 120.0 * I;
  } else if (norm1 <= 2.539398330063230e-1) {
    const Mat M2 = M * M;
    const Mat M4 = M2 * M2;
    U = M * (M4 + 420.0 * M2 + 15120.0 * I);
    V = 30.0 * M4 + 3360.0 * M2 + 30240.0 * I;
  } else if (norm1 <= 9.504178996162932e-1) {
    const Mat M2 = M * M;
    const Mat M4 = M2 * M2;
    const Mat M6 = M4 * M2;
    U = M * (M6 + 1512.0 * M4 + 277200.0 * M2 + 8648640.0 * I);
    V = 56.0 * M6 + 25200.0 * M4 + 1995840.0 * M2 + 17297280.0 * I;
  } else if (norm1 <= 2.097847961257068) {
    const Mat M2 = M * M;
    const Mat M4 = M2 * M2;
    const Mat M6 = M4 * M2;
    const Mat M8 = M6 * M2;
    U = M * (M8 + 3960.0 * M6 + 2162160.0 * M4 + 302702400.0 * M2 + 8821612800.0 * I);
    V = 90.0 * M8 + 110880.0 * M6 + 30270240.0 * M4 + 2075673600.0 * M2 + 17643225600.0 * I;
  } else {
    constexpr double kTheta13 = 5.371920351148152;
    if (norm1 > kTheta13) squarings = static_cast<int>(std::ceil(std::log2(norm1 / kTheta13)));
    const Mat A = M * std::ldexp(1.0, -squarings);
    const Mat A2 = A * A;
    const Mat A4 = A2 * A2;
    const Mat A6 = A4 * A2;
    const Mat U1 = A6 * (A6 + 16380.0 * A4 + 40840800.0 * A2);
    U = A *
        (U1 + 33522128640.0 * A6 + 10559470521600.0 * A4 + 1187353796428800.0 * A2 + 32382376266240000.0 * I);
    const Mat V1 = A6 * (182.0 * A6 + 960960.0 * A4 + 1323241920.0 * A2);
    V = V1 + 670442572800.0 * A6 + 129060195264000.0 * A4 + 7771770303897600.0 * A2 + 64764752532480000.0 * I;
  }
  const Eigen::PartialPivLU<Mat> lu(V - U);
  E = lu.solve(V + U);
  for (int k = 0; k < squarings; ++k) E = (E * E).eval();
  return E.allFinite();
}

/// Exact zero-order-hold discretisation of x' = A x + B u + c over dt (s):
/// Ad = e^{A dt}, Bd = int_0^dt e^{A s} ds B, cd = int_0^dt e^{A s} ds c, read off the single
/// exponential exp([[A, B, c], [0, 0, 0]] dt) of the (NX + NU + 1)-square augmented matrix.
/// @tparam NX state dimension (or Eigen::Dynamic, then taken from A).
/// @tparam NU input dimension (or Eigen::Dynamic, then taken from B).
/// @param A  continuous state matrix (1/s).
/// @param B  continuous input matrix (state units / (input units s)).
/// @param c  continuous affine term (state units / s).
/// @param dt step length (s).
/// @param Ad receives e^{A dt}.
/// @param Bd receives int_0^dt e^{A s} ds B.
/// @param cd receives int_0^dt e^{A s} ds c (state units).
/// @return false if an input or the result is not finite, or the sizes of A, B, c disagree.
template <int NX, int NU>
bool zoh_discretize(const Eigen::Matrix<double, NX, NX>& A, const Eigen::Matrix<double, NX, NU>& B,
                    const Eigen::Matrix<double, NX, 1>& c, double dt, Eigen::Matrix<double, NX, NX>& Ad,
                    Eigen::Matrix<double, NX, NU>& Bd, Eigen::Matrix<double, NX, 1>& cd) {
  constexpr int M = (NX == Eigen::Dynamic || NU == Eigen::Dynamic) ? Eigen::Dynamic : NX + NU + 1;
  const Eigen::Index n = A.rows(), m = B.cols();
  if (!std::isfinite(dt) || A.cols() != n || B.rows() != n || c.size() != n) return false;
  Eigen::Matrix<double, M, M> aug = Eigen::Matrix<double, M, M>::Zero(n + m + 1, n + m + 1);
  aug.topLeftCorner(n, n) = A * dt;
  aug.block(0, n, n, m) = B * dt;
  aug.block(0, n + m, n, 1) = c * dt;
  Eigen::Matrix<double, M, M> E;
  if (!expm<M>(aug, E)) return false;
  Ad = E.topLeftCorner(n, n);
  Bd = E.block(0, n, n, m);
  cd = E.block(0, n + m, n, 1);
  return true;
}

}  // namespace tubempc::math
