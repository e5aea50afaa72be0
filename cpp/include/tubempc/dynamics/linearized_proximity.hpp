/// @file linearized_proximity.hpp
/// The 6-DOF proximity model seen by the tube MPC (math::LinearizedModel): exact zero-order-hold
/// discretisation node by node or over a whole horizon, and the two linearised cone constraints
/// (docs/model.md, "Linearisation and discretisation", "Constraints").
#pragma once

#include <Eigen/Dense>
#include <Eigen/StdVector>
#include <memory>
#include <vector>

#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/math/linearized_model.hpp"

namespace tubempc::dynamics {

/// Preallocated storage of a discretised horizon: node k covers [t0 + k dt, t0 + (k+1) dt] with
/// x_{k+1} ~= A[k] x_k + B[k] u_k + c[k].
struct DiscreteHorizon {
  /// Allocates the nodes.
  /// @param N number of nodes, >= 1.
  /// @throws std::invalid_argument for N < 1.
  explicit DiscreteHorizon(int N);
  /// @return the number of nodes N.
  int size() const { return static_cast<int>(A.size()); }

  std::vector<StateMatrix, Eigen::aligned_allocator<StateMatrix>> A;  ///< A[k] = e^{A_c dt} (12 x 12)
  std::vector<InputMatrix, Eigen::aligned_allocator<InputMatrix>> B;  ///< B[k] (12 x 6)
  std::vector<StateVector, Eigen::aligned_allocator<StateVector>> c;  ///< c[k] (state units)
  int first_failed_node{-1};  ///< index of the first node whose discretisation failed, -1 if none
};

/// Default LinearizedProximityModel::position_tolerance (m): see `rediscretize`.
inline constexpr double kDefaultPositionTolerance = 0.3;

/// math::LinearizedModel over a ProximityModel. nx = 12, nu = 6, 2 constraint rows per node:
/// row 0 the glide slope, row 1 the line of sight, both tangent linearisations g(x_ref) +
/// grad g(x_ref) (x - x_ref) <= 0 (constraints.hpp).
class LinearizedProximityModel final : public math::LinearizedModel {
 public:
  /// @param model              the 6-DOF model, non-null.
  /// @param position_tolerance  largest change of r_L (m, per component) for which `rediscretize`
  ///                            keeps the translational blocks (see there); >= 0, finite.
  /// @throws std::invalid_argument for a null model or an invalid position_tolerance.
  explicit LinearizedProximityModel(std::shared_ptr<const ProximityModel> model,
                                    double position_tolerance = kDefaultPositionTolerance);

  int nx() const override { return kNx; }
  int nu() const override { return kNu; }
  int n_constraints() const override { return 2; }

  /// ProximityModel::discretize at the node's start time t. Sizes are checked
  /// (std::invalid_argument); a non-Ok status (non-finite input or result) throws std::domain_error
  /// because this interface has no status channel. Allocation-free.
  /// @param t     start time of the step (s).
  /// @param dt    step length (s).
  /// @param x_lin linearisation state (12).
  /// @param u_lin linearisation input (6).
  /// @param A     receives Ad (12 x 12).
  /// @param B     receives Bd (12 x 6).
  /// @param c     receives cd (12).
  void discretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                  const Eigen::Ref<const Eigen::VectorXd>& u_lin, Eigen::Ref<Eigen::MatrixXd> A,
                  Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const override;

  /// Re-discretisation that skips the gravity field when it can. The translational blocks (rows 0-5,
  /// columns 0-5 of A and 0-2 of B, c's head) depend on the linearisation point only through r_L
  /// (gravity; the Hill, Coriolis and input terms are linear), and attitude and translation are
  /// decoupled. So when the model has no extra acceleration, the incoming data are decoupled and r_L
  /// moved by at most position_tolerance() in every component, those blocks are kept and only the
  /// attitude blocks are recomputed (ProximityModel::discretize_rotation, ~5 us against ~100 us for
  /// the polyhedral field). The kept blocks are then the tangent model about a point at most
  /// position_tolerance() away: their slope differs from `discretize`'s by the change of the gravity
  /// gradient over that distance (~3e-9 1/s^2 at 250 m from Bennu for the default 0.3 m, against
  /// gradients of ~1e-7 1/s^2), and the state they predict at the new point (at most 1.9e-8 m and m/s
  /// per 2 s step along the default mission, against a disturbance of 0.02 m and 5 mm/s per step;
  /// docs/decisions.md). Otherwise this is `discretize`. Sizes and statuses as `discretize`;
  /// allocation-free.
  /// @param t      start time of the step (s).
  /// @param dt     step length (s).
  /// @param x_prev linearisation state of the incoming data (12).
  /// @param u_prev linearisation input of the incoming data (6).
  /// @param x_lin  new linearisation state (12).
  /// @param u_lin  new linearisation input (6).
  /// @param A      holds Ad about x_prev, receives Ad about x_lin (12 x 12).
  /// @param B      likewise Bd (12 x 6).
  /// @param c      likewise cd (12).
  /// @return whether the translational blocks about x_prev were kept.
  bool rediscretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x_prev,
                    const Eigen::Ref<const Eigen::VectorXd>& u_prev,
                    const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                    const Eigen::Ref<const Eigen::VectorXd>& u_lin, Eigen::Ref<Eigen::MatrixXd> A,
                    Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const override;

  /// @return the largest change of r_L (m) for which `rediscretize` keeps the translational blocks.
  double position_tolerance() const { return position_tolerance_; }

  /// G (2 x 12), h (2): glide slope and line of sight linearised at x_lin (the constraints do not
  /// depend on t). Allocation-free.
  /// @param t     time (s), unused.
  /// @param x_lin linearisation state (12).
  /// @param G     receives the constraint rows (2 x 12).
  /// @param h     receives the bounds (2; m).
  /// @throws std::domain_error at r = 0 or for a non-finite x_lin.
  void constraints(double t, const Eigen::Ref<const Eigen::VectorXd>& x_lin, Eigen::Ref<Eigen::MatrixXd> G,
                   Eigen::Ref<Eigen::VectorXd> h) const override;

  /// Discretises out.size() nodes about the columns of x_ref (12 x N) and u_ref (6 x N), node k at
  /// t0 + k dt. Returns the first non-Ok status (and sets out.first_failed_node) after trying all
  /// nodes. Allocation-free.
  /// @param t0    time of node 0 (s).
  /// @param dt    node length (s).
  /// @param x_ref linearisation states, one node per column (12 x N).
  /// @param u_ref linearisation inputs, one node per column (6 x N).
  /// @param out   receives the N nodes; its size sets N.
  /// @return DiscretizationStatus::Ok, or the first failure.
  DiscretizationStatus discretize_horizon(
      double t0, double dt, const Eigen::Ref<const Eigen::Matrix<double, kNx, Eigen::Dynamic>>& x_ref,
      const Eigen::Ref<const Eigen::Matrix<double, kNu, Eigen::Dynamic>>& u_ref, DiscreteHorizon& out) const;

  /// @return the 6-DOF model.
  const ProximityModel& model() const { return *model_; }

 private:
  std::shared_ptr<const ProximityModel> model_;
  double position_tolerance_;
};

}  // namespace tubempc::dynamics
