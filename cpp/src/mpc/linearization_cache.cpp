// The tube MPC's linearisation trajectory and per-node model data (see linearization_cache.hpp).
#include "linearization_cache.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace tubempc::mpc::detail {

void LinearizationCache::allocate(int nx, int nu, int nc, int N) {
  nc_ = nc;
  z_lin.setZero(nx, N + 1);
  v_lin.setZero(nu, N);
  z_lin_at = z_lin;
  v_lin_at = v_lin;
  z_anchor.setZero(nx, N);
  lin_k = -1;
  eval_d.setConstant(N, true);
  eval_c.setConstant(N + 1, true);
  Ad.assign(N, Eigen::MatrixXd::Zero(nx, nx));
  Bd.assign(N, Eigen::MatrixXd::Zero(nx, nu));
  cd.assign(N, Eigen::VectorXd::Zero(nx));
  Gc.assign(N + 1, Eigen::MatrixXd::Zero(nc, nx));
  hc.assign(N + 1, Eigen::VectorXd::Zero(nc));
  Ad_prev_ = Ad;
  Bd_prev_ = Bd;
  cd_prev_ = cd;
  Gc_prev_ = Gc;
  hc_prev_ = hc;
}

void LinearizationCache::begin_step(int k, int n, bool reuse, int& n_reuse_d, int& n_reuse_z) {
  n_reuse_d = 0;
  n_reuse_z = 0;
  if (reuse && ((lin_k >= 0 && k == lin_k + 1) || (primed_ && k == 0))) {
    n_reuse_z = std::min(n + 1, lin_n);
    n_reuse_d = std::min(n, lin_n - 1);
    std::rotate(Ad.begin(), Ad.begin() + 1, Ad.end());  // swaps: no allocation
    std::rotate(Bd.begin(), Bd.begin() + 1, Bd.end());
    std::rotate(cd.begin(), cd.begin() + 1, cd.end());
    std::rotate(Gc.begin(), Gc.begin() + 1, Gc.end());
    std::rotate(hc.begin(), hc.begin() + 1, hc.end());
    // Points and flags move with their data (ascending: column i + 1 is read before it is written).
    const Eigen::Index nd = eval_d.size(), ncs = eval_c.size();
    for (Eigen::Index i = 0; i < ncs; ++i) {
      if (i + 1 < ncs) z_lin_at.col(i) = z_lin_at.col(i + 1);
      eval_c(i) = i >= n_reuse_z || (i + 1 < ncs && eval_c(i + 1));
    }
    for (Eigen::Index i = 0; i < nd; ++i) {
      if (i + 1 < nd) v_lin_at.col(i) = v_lin_at.col(i + 1);
      if (i + 1 < nd) z_anchor.col(i) = z_anchor.col(i + 1);
      eval_d(i) = i >= n_reuse_d || (i + 1 < nd && eval_d(i + 1));
    }
  } else {
    eval_d.setConstant(true);
    eval_c.setConstant(true);
  }
  n_reused_d_ = n_reuse_d;
  lin_k = -1;  // valid again only if this step converges
  primed_ = false;
}

void LinearizationCache::prime(const math::LinearizedModel& model, const Reference& ref, double dt) {
  const Eigen::MatrixXd &z_ref = ref.z, &u_ref = ref.u;
  const double t0 = ref.t0;
  const int N = static_cast<int>(Ad.size()), T = static_cast<int>(u_ref.cols());
  Ad_ref_.assign(T, Eigen::MatrixXd::Zero(Ad[0].rows(), Ad[0].cols()));
  Bd_ref_.assign(T, Eigen::MatrixXd::Zero(Bd[0].rows(), Bd[0].cols()));
  cd_ref_.assign(T, Eigen::VectorXd::Zero(cd[0].size()));
  ref_ok_.setConstant(T, false);
  for (int j = 0; j < T; ++j) {
    try {
      model.discretize(t0 + static_cast<double>(j) * dt, dt, z_ref.col(j), u_ref.col(j), Ad_ref_[j],
                       Bd_ref_[j], cd_ref_[j]);
      ref_ok_(j) = Ad_ref_[j].allFinite() && Bd_ref_[j].allFinite() && cd_ref_[j].allFinite();
    } catch (const std::domain_error&) {
      ref_ok_(j) = false;  // a node the model cannot discretise: the step evaluates (and reports) it itself
    }
  }
  const int n0 = std::min(N, T);  // horizon of the step at k = 0
  // Slot j holds node j - 1 of the step at k = 0 (begin_step shifts it by one node).
  bool finite = true;
  for (int j = 1; j <= n0; ++j) {
    const double t = t0 + static_cast<double>(j - 1) * dt;
    z_lin_at.col(j) = z_ref.col(j - 1);
    if (nc_ > 0) {
      model.constraints(t, z_lin_at.col(j), Gc[j], hc[j]);
      finite = finite && Gc[j].allFinite() && !hc[j].array().isNaN().any() && !(hc[j].array() == -kInf).any();
    }
    if (j == n0) break;
    v_lin_at.col(j) = u_ref.col(j - 1);
    z_anchor.col(j) = z_ref.col(j - 1);
    Ad[j] = Ad_ref_[j - 1];
    Bd[j] = Bd_ref_[j - 1];
    cd[j] = cd_ref_[j - 1];
    finite = finite && ref_ok_(j - 1);
  }
  lin_k = -1;
  lin_n = n0;
  eval_d.setConstant(false);  // data about the reference itself: no node is pending
  eval_c.setConstant(false);
  primed_ = finite;  // otherwise the first step evaluates (and reports) them itself
}

bool LinearizationCache::discretize_at(const math::LinearizedModel& model, const Reference& ref, int j,
                                       double dt, const Eigen::Ref<const Eigen::VectorXd>& x,
                                       const Eigen::Ref<const Eigen::VectorXd>& u,
                                       Eigen::Ref<Eigen::MatrixXd> A, Eigen::Ref<Eigen::MatrixXd> B,
                                       Eigen::Ref<Eigen::VectorXd> c) const {
  const double t = ref.t0 + static_cast<double>(j) * dt;
  if (j < 0 || j >= ref_ok_.size() || !ref_ok_(j)) {
    model.discretize(t, dt, x, u, A, B, c);
    return false;
  }
  A = Ad_ref_[j];
  B = Bd_ref_[j];
  c = cd_ref_[j];
  return model.rediscretize(t, dt, ref.z.col(j), ref.u.col(j), x, u, A, B, c);
}

Status LinearizationCache::evaluate(const math::LinearizedModel& model, const Reference& ref, int k,
                                    double dt, int n, int it, const Mask& mA, const Mask& mB, const Mask& mG,
                                    int& model_evaluations) {
  const auto t_node = [&](int i) { return ref.t0 + static_cast<double>(k + i) * dt; };
  bool finite = true;
  for (int i = 0; i < n; ++i) {
    if (!eval_d(i)) continue;
    if (it > 0 || i < n_reused_d_) {  // data for the same time about z_anchor: the model may keep parts
      if (!model.rediscretize(t_node(i), dt, z_anchor.col(i), v_lin_at.col(i), z_lin.col(i), v_lin.col(i),
                              Ad[i], Bd[i], cd[i]))
        z_anchor.col(i) = z_lin.col(i);
    } else {  // a new node: from the reference's data at its time, where it has some
      const int j = k + i;
      const bool kept = discretize_at(model, ref, j, dt, z_lin.col(i), v_lin.col(i), Ad[i], Bd[i], cd[i]);
      if (kept)
        z_anchor.col(i) = ref.z.col(j);
      else
        z_anchor.col(i) = z_lin.col(i);
    }
    finite = finite && Ad[i].allFinite() && Bd[i].allFinite() && cd[i].allFinite();
    ++model_evaluations;
  }
  for (int i = 0; i <= n; ++i) {
    if (nc_ == 0) break;
    if (!eval_c(i)) continue;
    model.constraints(t_node(i), z_lin.col(i), Gc[i], hc[i]);
    finite = finite && Gc[i].allFinite() && !hc[i].array().isNaN().any() && !(hc[i].array() == -kInf).any();
  }
  z_lin_at = z_lin;
  v_lin_at = v_lin;
  if (!finite) return Status::NumericalError;
  bool structured = true;
  for (int i = 0; i < n; ++i)
    structured = structured && !outside_structure(Ad[i], mA) && !outside_structure(Bd[i], mB);
  for (int i = 0; i <= n && nc_ > 0; ++i) structured = structured && !outside_structure(Gc[i], mG);
  return structured ? Status::Solved : Status::ModelStructure;
}

bool LinearizationCache::same_as_last(int it, int n, bool trust_region_inactive) {
  bool same = it > 0 && trust_region_inactive;
  for (int i = 0; i < n && same; ++i)
    same = Ad[i] == Ad_prev_[i] && Bd[i] == Bd_prev_[i] && cd[i] == cd_prev_[i];
  for (int i = 0; i <= n && same && nc_ > 0; ++i) same = Gc[i] == Gc_prev_[i] && hc[i] == hc_prev_[i];
  if (same) return true;
  for (int i = 0; i < n; ++i) {
    Ad_prev_[i] = Ad[i];
    Bd_prev_[i] = Bd[i];
    cd_prev_[i] = cd[i];
  }
  for (int i = 0; i <= n && nc_ > 0; ++i) {
    Gc_prev_[i] = Gc[i];
    hc_prev_[i] = hc[i];
  }
  return false;
}

void LinearizationCache::update(const Eigen::MatrixXd& z_star, const Eigen::MatrixXd& v_star, int n,
                                bool reuse, double scp_eps) {
  const int N = static_cast<int>(v_star.cols());
  for (int i = 0; i <= N; ++i) {
    const bool moved = !reuse || i > n || (z_star.col(i) - z_lin.col(i)).cwiseAbs().maxCoeff() >= scp_eps;
    eval_c(i) = moved;
    if (i < N) eval_d(i) = moved;
    if (!moved) continue;
    z_lin.col(i) = z_star.col(i);
    if (i < N) v_lin.col(i) = v_star.col(i);
  }
}

}  // namespace tubempc::mpc::detail
