#include "tubempc/dynamics/linearized_proximity.hpp"

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

LinearizedProximityModel::LinearizedProximityModel(std::shared_ptr<const ProximityModel> model)
    : model_(std::move(model)) {
  if (!model_) throw std::invalid_argument("LinearizedProximityModel: model must not be null");
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

void LinearizedProximityModel::constraints(double /*t*/, const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                                           Eigen::Ref<Eigen::MatrixXd> G,
                                           Eigen::Ref<Eigen::VectorXd> h) const {
  check_size(x_lin.rows(), 1, kNx, 1, "x_lin");
  check_size(G.rows(), G.cols(), 2, kNx, "G");
  check_size(h.rows(), 1, 2, 1, "h");
  const StateVector x = x_lin;
  const ModelParams& p = model_->params();
  StateVector grad;
  const double g_gs = glide_slope_constraint(x, p.glide_slope_angle, &grad);
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
