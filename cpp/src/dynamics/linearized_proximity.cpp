#include "tubempc/dynamics/linearized_proximity.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "tubempc/dynamics/constraints.hpp"

namespace tubempc::dynamics {
namespace {

void check_size(Eigen::Index rows, Eigen::Index cols, Eigen::Index want_rows, Eigen::Index want_cols,
                const char* name) {
  if (rows != want_rows || cols != want_cols) {
    throw std::invalid_argument(std::string("LinearizedProximityModel: ") + name + " must be " +
                                std::to_string(want_rows) + "x" + std::to_string(want_cols) + ", got " +
                                std::to_string(rows) + "x" + std::to_string(cols));
  }
}

}  // namespace

DiscreteHorizon::DiscreteHorizon(int N) {
  if (N < 1) throw std::invalid_argument("DiscreteHorizon: N must be >= 1, got " + std::to_string(N));
  A.resize(static_cast<std::size_t>(N));
  B.resize(static_cast<std::size_t>(N));
  c.resize(static_cast<std::size_t>(N));
}

LinearizedProximityModel::LinearizedProximityModel(std::shared_ptr<const ProximityModel> model,
                                                   double position_tolerance)
    : model_(std::move(model)), position_tolerance_(position_tolerance) {
  if (!model_) throw std::invalid_argument("LinearizedProximityModel: model must not be null");
  if (!(position_tolerance >= 0.0) || !std::isfinite(position_tolerance)) {
    throw std::invalid_argument("LinearizedProximityModel: position_tolerance must be finite and >= 0, got " +
                                std::to_string(position_tolerance));
  }
}

void LinearizedProximityModel::discretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                                          const Eigen::Ref<const Eigen::VectorXd>& u_lin,
                                          Eigen::Ref<Eigen::MatrixXd> A, Eigen::Ref<Eigen::MatrixXd> B,
                                          Eigen::Ref<Eigen::VectorXd> c) const {
  check_size(x_lin.rows(), 1, kNx, 1, "x_lin");
  check_size(u_lin.rows(), 1, kNu, 1, "u_lin");
  check_size(A.rows(), A.cols(), kNx, kNx, "A");
  check_size(B.rows(), B.cols(), kNx, kNu, "B");
  check_size(c.rows(), 1, kNx, 1, "c");
  const StateVector x = x_lin;
  const InputVector u = u_lin;
  StateMatrix Ad;
  InputMatrix Bd;
  StateVector cd;
  const DiscretizationStatus st = model_->discretize(t, dt, x, u, Ad, Bd, cd);
  if (st != DiscretizationStatus::Ok) {
    throw std::domain_error(std::string("LinearizedProximityModel::discretize: ") + to_string(st) +
                            " at t = " + std::to_string(t));
  }
  A = Ad;
  B = Bd;
  c = cd;
}

bool LinearizedProximityModel::rediscretize(double t, double dt,
                                            const Eigen::Ref<const Eigen::VectorXd>& x_prev,
                                            const Eigen::Ref<const Eigen::VectorXd>& u_prev,
                                            const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                                            const Eigen::Ref<const Eigen::VectorXd>& u_lin,
                                            Eigen::Ref<Eigen::MatrixXd> A, Eigen::Ref<Eigen::MatrixXd> B,
                                            Eigen::Ref<Eigen::VectorXd> c) const {
  check_size(x_prev.rows(), 1, kNx, 1, "x_prev");
  check_size(u_prev.rows(), 1, kNu, 1, "u_prev");
  check_size(x_lin.rows(), 1, kNx, 1, "x_lin");
  check_size(u_lin.rows(), 1, kNu, 1, "u_lin");
  check_size(A.rows(), A.cols(), kNx, kNx, "A");
  check_size(B.rows(), B.cols(), kNx, kNu, "B");
  check_size(c.rows(), 1, kNx, 1, "c");
  const bool keep_translation =
      std::isfinite(t) && !model_->extra_acceleration() && x_prev.allFinite() && x_lin.allFinite() &&
      (x_lin.head<3>() - x_prev.head<3>()).cwiseAbs().maxCoeff() <= position_tolerance_ &&
      A.topLeftCorner<6, 6>().allFinite() && B.topLeftCorner<6, 3>().allFinite() && c.head<6>().allFinite() &&
      A.topRightCorner<6, 6>().isZero(0.0) && A.bottomLeftCorner<6, 6>().isZero(0.0) &&
      B.topRightCorner<6, 3>().isZero(0.0) && B.bottomLeftCorner<6, 3>().isZero(0.0);
  if (!keep_translation) {
    discretize(t, dt, x_lin, u_lin, A, B, c);
    return false;
  }
  Eigen::Matrix<double, 6, 6> Ad_r;
  Eigen::Matrix<double, 6, 3> Bd_r;
  Eigen::Matrix<double, 6, 1> cd_r;
  const DiscretizationStatus st = model_->discretize_rotation(dt, x_lin.segment<3>(6), x_lin.segment<3>(9),
                                                              u_lin.segment<3>(3), Ad_r, Bd_r, cd_r);
  if (st != DiscretizationStatus::Ok) {
    throw std::domain_error(std::string("LinearizedProximityModel::rediscretize: ") + to_string(st) +
                            " at t = " + std::to_string(t));
  }
  A.bottomRightCorner<6, 6>() = Ad_r;
  B.bottomRightCorner<6, 3>() = Bd_r;
  c.tail<6>() = cd_r;
  return true;
}

void LinearizedProximityModel::constraints(double t, const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                                           Eigen::Ref<Eigen::MatrixXd> G,
                                           Eigen::Ref<Eigen::VectorXd> h) const {
  check_size(x_lin.rows(), 1, kNx, 1, "x_lin");
  check_size(G.rows(), G.cols(), 2, kNx, "G");
  check_size(h.rows(), 1, 2, 1, "h");
  const StateVector x = x_lin;
  const ModelParams& p = model_->params();
  StateVector grad;
  Eigen::Vector3d apex_L, axis_L;
  model_->glide_slope_cone_L(t, apex_L, axis_L);
  const double g_gs = glide_slope_constraint(x, p.glide_slope_angle, apex_L, axis_L, &grad);
  G.row(0) = grad.transpose();
  h(0) = linearized_bound(g_gs, grad, x);
  const double g_los = line_of_sight_constraint(x, p.los_angle, p.boresight_B, &grad);
  G.row(1) = grad.transpose();
  h(1) = linearized_bound(g_los, grad, x);
}

DiscretizationStatus LinearizedProximityModel::discretize_horizon(
    double t0, double dt, const Eigen::Ref<const Eigen::Matrix<double, kNx, Eigen::Dynamic>>& x_ref,
    const Eigen::Ref<const Eigen::Matrix<double, kNu, Eigen::Dynamic>>& u_ref, DiscreteHorizon& out) const {
  const int N = out.size();
  if (x_ref.cols() != N || u_ref.cols() != N) {
    throw std::invalid_argument("LinearizedProximityModel::discretize_horizon: x_ref and u_ref need " +
                                std::to_string(N) + " columns, got " + std::to_string(x_ref.cols()) +
                                " and " + std::to_string(u_ref.cols()));
  }
  DiscretizationStatus first = DiscretizationStatus::Ok;
  out.first_failed_node = -1;
  for (int k = 0; k < N; ++k) {
    const StateVector x = x_ref.col(k);
    const InputVector u = u_ref.col(k);
    const auto ks = static_cast<std::size_t>(k);
    const DiscretizationStatus st =
        model_->discretize(t0 + k * dt, dt, x, u, out.A[ks], out.B[ks], out.c[ks]);
    if (st != DiscretizationStatus::Ok && first == DiscretizationStatus::Ok) {
      first = st;
      out.first_failed_node = k;
    }
  }
  return first;
}

}  // namespace tubempc::dynamics
