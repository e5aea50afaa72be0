// LtiModel (lti_model.hpp): exact zero-order hold of a continuous LTI system, fixed constraints.
#include "tubempc/mpc/lti_model.hpp"

#include <stdexcept>

#include "tubempc/math/expm.hpp"

namespace tubempc::mpc {

LtiModel::LtiModel(const Eigen::MatrixXd& A_c, const Eigen::MatrixXd& B_c, const Eigen::VectorXd& c_c,
                   double dt, const Eigen::MatrixXd& G, const Eigen::VectorXd& h)
    : dt_(dt), G_(G), h_(h) {
  if (!(dt > 0.0)) throw std::invalid_argument("LtiModel: dt must be > 0 s");
  if (G.cols() != A_c.rows() || G.rows() != h.size())
    throw std::invalid_argument("LtiModel: G, h sizes mismatch");
  if (A_c.cols() != A_c.rows() || B_c.rows() != A_c.rows() || c_c.size() != A_c.rows())
    throw std::invalid_argument("LtiModel: inconsistent sizes of A_c, B_c, c_c");
  if (!math::zoh_discretize<Eigen::Dynamic, Eigen::Dynamic>(A_c, B_c, c_c, dt, A_, B_, c_))
    throw std::invalid_argument("LtiModel: A_c, B_c, c_c must be finite");
}

void LtiModel::discretize(double, double dt, const Eigen::Ref<const Eigen::VectorXd>&,
                          const Eigen::Ref<const Eigen::VectorXd>&, Eigen::Ref<Eigen::MatrixXd> A,
                          Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const {
  if (dt != dt_) throw std::invalid_argument("LtiModel::discretize: dt differs from the construction's");
  A = A_;
  B = B_;
  c = c_;
}

void LtiModel::constraints(double, const Eigen::Ref<const Eigen::VectorXd>&, Eigen::Ref<Eigen::MatrixXd> G,
                           Eigen::Ref<Eigen::VectorXd> h) const {
  G = G_;
  h = h_;
}

}  // namespace tubempc::mpc
