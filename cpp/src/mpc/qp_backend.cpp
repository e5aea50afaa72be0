// QP solvers of the tube MPC's step (see qp_backend.hpp).
#include "qp_backend.hpp"

#include <algorithm>

namespace tubempc::mpc::detail {

PiqpBackend::PiqpBackend(const QpProblem& qp, const Settings& s) {
  piqp::Settings<double>& ps = solver_.settings();
  ps.eps_abs = s.qp_eps_abs;
  ps.eps_rel = s.qp_eps_rel;
  ps.eps_duality_gap_abs = s.qp_eps_abs;
  ps.eps_duality_gap_rel = s.qp_eps_rel;
  ps.max_iter = s.qp_max_iterations;
  ps.kkt_solver = s.kkt_solver == KktSolver::SparseMultistage ? piqp::KKTSolver::sparse_multistage
                                                              : piqp::KKTSolver::sparse_ldlt;
  ps.compute_timings = false;
  ps.reg_lower_limit = s.qp_reg_lower_limit;
  ps.preconditioner_scale_cost = s.qp_scale_cost;
  ps.preconditioner_iter = s.qp_preconditioner_iterations;
  solver_.setup(qp.P, qp.q, qp.A, qp.b, qp.G, qp.h_l, qp.h_u, qp.x_l, qp.x_u);
}

// One retry at a higher regularisation floor (same data, same solver: no allocation).
Status PiqpBackend::solve(const QpProblem& qp, const Settings& s, StepResult& res,
                          Clock::time_point t_start) {
  solver_.update(qp.P, qp.q, qp.A, qp.b, qp.G, qp.h_l, qp.h_u, qp.x_l, qp.x_u);
  piqp::Status qs = solver_.solve();
  const auto& r = solver_.result();
  res.qp_iterations += static_cast<int>(r.info.iter);
  const auto capped_inaccurate = [&] {
    return qs == piqp::Status::PIQP_MAX_ITER_REACHED && r.info.primal_res_rel <= s.qp_inaccurate_tol &&
           r.info.dual_res_rel <= s.qp_inaccurate_tol;
  };
  if ((qs == piqp::Status::PIQP_NUMERICS ||
       (qs == piqp::Status::PIQP_MAX_ITER_REACHED && !capped_inaccurate())) &&
      s.qp_retry_reg_lower_limit > 0.0 && seconds_since(t_start) < s.time_limit) {
    piqp::Settings<double>& ps = solver_.settings();
    ps.reg_lower_limit = s.qp_retry_reg_lower_limit;
    qs = solver_.solve();
    ps.reg_lower_limit = s.qp_reg_lower_limit;
    res.qp_iterations += static_cast<int>(r.info.iter);
  }
  if (qs == piqp::Status::PIQP_INVALID_SETTINGS) return Status::NotSolved;
  if (qs == piqp::Status::PIQP_PRIMAL_INFEASIBLE || qs == piqp::Status::PIQP_DUAL_INFEASIBLE)
    return Status::Infeasible;
  if (capped_inaccurate()) return Status::SolvedInaccurate;
  if (qs != piqp::Status::PIQP_SOLVED)
    return qs == piqp::Status::PIQP_NUMERICS ? Status::NumericalError : Status::NotSolved;
  return Status::Solved;
}

QpSolution PiqpBackend::solution() const {
  const auto& r = solver_.result();
  return QpSolution{r.x, r.y, r.z_l, r.z_u, r.z_bl, r.z_bu};
}

ActiveSetBackend::ActiveSetBackend(const QpProblem& qp, const QpLayout& layout, const QpLayout* longer,
                                   const Settings& s)
    : piqp_(qp, s) {
  ActiveSetQp::Settings as;
  as.max_iterations = s.active_set_max_iterations;
  as.eps_abs = s.qp_eps_abs;
  as.eps_rel = s.qp_eps_rel;
  active_set_.setup(qp.P, qp.A, qp.G, layout.boundable(s), as);
  if (layout.off_t >= 0) {  // the soft-terminal rows |dz_N| <= t are exact L1 penalty pairs
    Eigen::Array<bool, Eigen::Dynamic, 1> penalty =
        Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(layout.n_in, false);
    penalty.segment(layout.terminal_row(), 2 * layout.nx).setConstant(true);
    active_set_.set_penalty_rows(penalty);
  }
  set_.setZero(layout.n_in + layout.n_var);
  prev_ = set_;
  shift_ = layout.shift_map(layout);
  if (longer != nullptr) {
    shift_longer_ = layout.shift_map(*longer);
    longer_set_size_ = longer->n_in + longer->n_var;
  }
}

void ActiveSetBackend::begin_step(int k, const QpBackend& previous) {
  const Eigen::VectorXi* last = previous.final_set(k - 1);
  if (last == &set_) {
    prev_ = set_;
    for (int j = 0; j < set_.size(); ++j) set_(j) = prev_(shift_(j));
  } else if (last != nullptr && last->size() == longer_set_size_) {
    for (int j = 0; j < set_.size(); ++j) set_(j) = (*last)(shift_longer_(j));
  } else {
    set_.setZero();
  }
  set_k_ = -1;  // valid again only if this step returns a plan
}

Status ActiveSetBackend::solve(const QpProblem& qp, const Settings& s, StepResult& res,
                               Clock::time_point t_start) {
  by_active_set_ = false;
  const bool warm = (set_.array() != 0).any();
  for (int attempt = 0; attempt < (warm ? 2 : 1) && !by_active_set_; ++attempt) {
    if (attempt == 1) set_.setZero();
    by_active_set_ = active_set_.solve(qp.P, qp.q, qp.A, qp.b, qp.G, qp.h_l, qp.h_u, qp.x_l, qp.x_u, set_) ==
                     ActiveSetQp::Status::Solved;
    res.active_set_iterations += active_set_.info().iterations;
    res.active_set_refinements += active_set_.info().refinements;
    if (!by_active_set_) ++res.active_set_failures;
  }
  if (by_active_set_) {
    ++res.active_set_solves;
    return Status::Solved;
  }
  const Status st = piqp_.solve(qp, s, res, t_start);
  if (st == Status::Solved || st == Status::SolvedInaccurate) set_from_piqp();
  return st;
}

// Active set read off PIQP's multipliers (the warm start of the next QP after a PIQP solve).
void ActiveSetBackend::set_from_piqp() {
  const auto& r = piqp_.result();
  const double scale = std::max({1.0, r.z_l.lpNorm<Eigen::Infinity>(), r.z_u.lpNorm<Eigen::Infinity>(),
                                 r.z_bl.lpNorm<Eigen::Infinity>(), r.z_bu.lpNorm<Eigen::Infinity>()});
  const double tol = 1e-6 * scale;
  const int n_in = static_cast<int>(r.z_l.size()), n_var = static_cast<int>(r.x.size());
  for (int i = 0; i < n_in; ++i) set_(i) = r.z_u(i) > tol ? 1 : (r.z_l(i) > tol ? -1 : 0);
  for (int j = 0; j < n_var; ++j) set_(n_in + j) = r.z_bu(j) > tol ? 1 : (r.z_bl(j) > tol ? -1 : 0);
}

QpSolution ActiveSetBackend::solution() const {
  if (!by_active_set_) return piqp_.solution();
  const ActiveSetQp& as = active_set_;
  return QpSolution{as.w(), as.y(), as.z_l(), as.z_u(), as.z_bl(), as.z_bu()};
}

std::unique_ptr<QpBackend> make_qp_backend(const QpProblem& qp, const QpLayout& layout,
                                           const QpLayout* longer, const Settings& s) {
  if (s.qp_solver == QpSolver::Piqp) return std::make_unique<PiqpBackend>(qp, s);
  return std::make_unique<ActiveSetBackend>(qp, layout, longer, s);
}

}  // namespace tubempc::mpc::detail
