/// @file polyhedron_gravity.hpp
/// Gravity field of a constant-density polyhedron (Werner and Scheeres 1997; docs/model.md,
/// "Gravity", paper Eq. (2)-(7)), exact for the mesh, evaluated in the body-fixed frame A:
///
///     U      =  G rho/2 (sum_e r_e^T E_e r_e L_e - sum_f r_f^T F_f r_f w_f)      (m^2/s^2, > 0)
///     grad U = -G rho   (sum_e E_e r_e L_e     - sum_f F_f r_f w_f)            (m/s^2)
///     Hess U =  G rho   (sum_e E_e L_e         - sum_f F_f w_f)                (1/s^2)
///     Laplacian U = trace Hess U = -G rho sum_f w_f
///
/// with r_e, r_f vectors from the field point to a point of edge e / face f, the edge dyads
/// E_e = n_A n_12^A^T + n_B n_21^B^T, the face dyads F_f = n_f n_f^T,
/// L_e = ln((a+b+e)/(a+b-e)) (a, b distances to the edge's ends, e its length) and the signed solid
/// angle w_f = 2 atan2(r1.(r2 x r3), r1 r2 r3 + r1 (r2.r3) + r2 (r3.r1) + r3 (r1.r2)).
///
/// Numerics: every quantity is formed from vectors relative to the mesh's centre of mass and from
/// vertex-relative distances; the numerator of w_f is |N_f| n_f.(v1 - r) and the dot products of its
/// denominator use the law of cosines with the exact edge lengths, so no triple product of large
/// vectors is formed; L_e is evaluated as log1p(2e/(a+b-e)) (Eigen's vectorised log of u = 1 + x
/// corrected by u's rounding error), which keeps its relative accuracy far from the body where
/// (a+b+e)/(a+b-e) -> 1. The arc
/// tangent (Cephes, <= 1 ulp) is evaluated in vectorised blocks. What remains is the formula's own
/// cancellation far away, which grows like (|r|/R)^2 (R the body's size). Relative errors on the
/// Bennu radar model against an 80-bit evaluation of the same formulas (U, a): 3e-15, 6e-15 at
/// 1 km; 1e-13, 3e-13 at 5 km; 7e-13, 4e-12 at 20 km; 1e-11, 8e-11 at 100 km (polyhedral-gravity
/// 3.3.1: 1e-13, 7e-13; 2e-11, 2e-10; 4e-10, 5e-9; 7e-8, 7e-7). Beyond kFarFieldFactor R_max from
/// the centre of mass (R_max the largest vertex distance from it; 116 km for Bennu) the exterior
/// expansion to degree 2 (point mass plus MacCullagh's quadrupole from the inertia tensor) is
/// returned instead; its truncation error, O((R/|r|)^3), only decreases from there and it stays
/// exact up to |r| ~ 1e150 m. At the switch the two agree to 2e-10 (U), 6e-10 (a) and 1.5e-9
/// (Hess U) relative on the radar model; the Laplacian there is 0.
///
/// Points on the surface (limit values; G = Hess U is discontinuous across a face and diverges
/// logarithmically at edges and vertices):
/// - A face whose plane contains the point (|n_f.(v1 - r)| <= 16 eps (|r - c| + R_max), c the centre
///   of mass and R_max the largest vertex distance from it) contributes w_f = 0 (its principal
///   value). U and grad U are continuous and take their exact limit values. On a face interior the
///   returned Hessian and Laplacian are the means of the inside and outside limits (Laplacian
///   -2 pi G rho); in general the Laplacian is -G rho times the solid angle of the body seen from
///   the point (4 pi inside, 2 pi on a face, the interior solid angle at an edge or vertex).
/// - The denominator of L_e is guarded, a+b-e >= eps (a+b+e), so L_e <= ln(1/eps) ~ 36: this only
///   acts within about 1e-8 edge lengths of an edge, where a+b-e is lost to rounding. On an edge or
///   vertex U and grad U are the exact limits (the term E_e r_e L_e vanishes there) and the returned
///   Hessian is finite but not a limit (the divergent L_e is cut off at ln(1/eps)).
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <vector>

#include "tubempc/gravity/gravity_model.hpp"
#include "tubempc/gravity/shape.hpp"

namespace tubempc::gravity {

/// Newton's gravitational constant (m^3 kg^-1 s^-2), CODATA 2018.
inline constexpr double kGravitationalConstant = 6.67430e-11;

/// Distance from the centre of mass, in units of the largest vertex distance, beyond which
/// PolyhedronGravity returns the degree-2 exterior expansion (see the file comment).
inline constexpr double kFarFieldFactor = 400.0;

/// Points, one per row (m).
using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// Gravity gradients, one row-major 3 x 3 matrix per row (1/s^2).
using Gradients = Eigen::Matrix<double, Eigen::Dynamic, 9, Eigen::RowMajor>;

/// Constant-density polyhedron gravity (see the file comment for formulas, units and the values
/// returned on the surface). Immutable after construction; `evaluate` and `laplacian` neither
/// allocate nor lock and may be called from several threads at once.
class PolyhedronGravity final : public GravityModel {
 public:
  /// @param shape   validated closed mesh (m).
  /// @param density constant density (kg/m^3), finite and > 0.
  /// @throws std::invalid_argument for a bad density.
  PolyhedronGravity(Shape shape, double density);

  /// U, grad U and Hess U at a point.
  /// @param r_A position in frame A (m), finite with |r_A| < 1e150 m.
  /// @param out receives U (m^2/s^2), a = grad U (m/s^2) and G = Hess U (1/s^2).
  /// @throws std::domain_error for a non-finite or too large r_A.
  void evaluate(const Eigen::Vector3d& r_A, GravitySample& out) const override;

  /// a = grad U alone (the sums of `evaluate` without the Hessian's; the same value to the bit).
  /// @param r_A position in frame A (m), finite with |r_A| < 1e150 m.
  /// @return a (m/s^2) in frame A.
  /// @throws std::domain_error for a non-finite or too large r_A.
  Eigen::Vector3d acceleration(const Eigen::Vector3d& r_A) const override;

  /// Laplacian of U at a point.
  /// @param r_A position in frame A (m), finite with |r_A| < 1e150 m.
  /// @return -G rho sum_f w_f (1/s^2): 0 outside, -4 pi G rho inside.
  /// @throws std::domain_error for a non-finite or too large r_A.
  double laplacian(const Eigen::Vector3d& r_A) const;

  /// Evaluates at every row of r_A. Results do not depend on the number of threads. Allocates only
  /// the threads.
  /// @param r_A          points in frame A (m), n x 3.
  /// @param potential    receives U (m^2/s^2), n.
  /// @param acceleration receives a (m/s^2), n x 3.
  /// @param gradient     receives G (1/s^2), n x 9 (row-major 3 x 3 per row).
  /// @param threads      threads to use; 0: std::thread::hardware_concurrency.
  /// @throws std::invalid_argument if an output does not have n rows, a point is not finite or has
  ///         |r| >= 1e150 m, or threads < 0.
  void evaluate_batch(const Eigen::Ref<const Points>& r_A, Eigen::Ref<Eigen::VectorXd> potential,
                      Eigen::Ref<Points> acceleration, Eigen::Ref<Gradients> gradient, int threads = 1) const;

  /// Laplacian at every row of r_A.
  /// @param r_A       points in frame A (m), n x 3.
  /// @param laplacian receives the Laplacian of U (1/s^2), n.
  /// @param threads   threads to use; 0: hardware threads.
  /// @throws std::invalid_argument if laplacian does not have n rows, a point is not finite or has
  ///         |r| >= 1e150 m, or threads < 0.
  void laplacian_batch(const Eigen::Ref<const Points>& r_A, Eigen::Ref<Eigen::VectorXd> laplacian,
                       int threads = 1) const;

  /// @return G M = G rho V (m^3/s^2).
  double gm() const override { return kGravitationalConstant * mass(); }
  /// @return the density rho (kg/m^3).
  double density() const { return density_; }
  /// @return the mass rho V (kg).
  double mass() const { return density_ * shape_.volume(); }
  /// @return the mesh (m).
  const Shape& shape() const { return shape_; }

 private:
  // Per-point work of one cluster of faces (see the constructor): partial sums.
  struct Sums;
  // What accumulate sums: the faces' solid angles only, also U and a, or also Hess U.
  enum class Terms { Laplacian, Acceleration, All };
  template <Terms kTerms>
  void accumulate(const Eigen::Vector3d& p, double tol_plane, Sums& s) const;
  // Degree-2 exterior expansion at p (relative to the centre of mass), |p| = r.
  void far_field(const Eigen::Vector3d& p, double r, GravitySample& out) const;

  Shape shape_;
  double density_;
  double g_rho_;
  Eigen::Vector3d center_;  // centre of mass: all mesh data is stored relative to it
  double r_max_{0.0};       // largest vertex distance from the centre (m)
  double r_far_{0.0};       // kFarFieldFactor r_max_ (m)
  Eigen::Matrix3d quadrupole_{Eigen::Matrix3d::Zero()};  // G (tr I Id - 3 I) (m^5/s^2)

  // The mesh is split into clusters of at most kMaxClusterVertices vertices (patches grown over
  // face adjacency); each cluster stores copies of its vertices, its faces and the edges whose
  // face_a is in it, with cluster-local vertex indices, so that per-point vertex data fits in
  // fixed-size stack buffers. Arrays are structure-of-arrays, concatenated over clusters.
  struct Cluster {
    std::int32_t v_begin, v_count, e_begin, e_count, f_begin, f_count;
  };
  std::vector<Cluster> clusters_;
  std::vector<double> vx_, vy_, vz_;                             // vertices relative to the centre (m)
  std::vector<std::uint16_t> e_i_, e_j_;                         // edge ends (cluster-local)
  std::vector<double> e_len_;                                    // edge length (m)
  std::vector<double> e_xx_, e_xy_, e_xz_, e_yy_, e_yz_, e_zz_;  // E_e (symmetric)
  std::vector<double> e_evx_, e_evy_, e_evz_;                    // E_e v_i (m)
  std::vector<double> e_vev_;                                    // v_i^T E_e v_i (m^2)
  std::vector<std::uint16_t> f_i_, f_j_, f_k_;                   // face vertices (cluster-local)
  std::vector<double> f_nx_, f_ny_, f_nz_;                       // unit outward normal
  std::vector<double> f_d_;                                      // n_f . v1 (m)
  std::vector<double> f_n2_;                                     // |N_f| = 2 area (m^2)
  std::vector<double> f_l12_, f_l23_, f_l31_;                    // squared side lengths (m^2)
};

}  // namespace tubempc::gravity
