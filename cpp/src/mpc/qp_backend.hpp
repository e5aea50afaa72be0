// QP solvers of the tube MPC's step (not installed): one small interface, chosen once at setup from
// Settings::qp_solver (make_qp_backend). PiqpBackend: PIQP's interior point with a retry at a higher
// regularisation floor. ActiveSetBackend: the warm-started active set (ActiveSetQp) with PIQP where
// it does not verify.
#pragma once

#include <memory>
#include <piqp/piqp.hpp>

#include "qp_layout.hpp"
#include "tubempc/mpc/active_set_qp.hpp"
#include "tubempc/mpc/results.hpp"

namespace tubempc::mpc::detail {

class QpBackend {
 public:
  virtual ~QpBackend() = default;
  // Start of step k: a warm start may use the final state of step k - 1 (solved by `previous`, this
  // backend or, in the shrinking phase, the backend of one node more) if that step returned a plan.
  virtual void begin_step(int k, const QpBackend& previous) = 0;
  // The active set (G rows, then variables) of step k's last QP if step k returned a plan and this
  // backend has one, else nullptr.
  virtual const Eigen::VectorXi* final_set(int k) const = 0;
  // Step k returned a plan (its solver state may warm-start step k + 1).
  virtual void plan_applied(int k) = 0;
  // Forgets the warm start.
  virtual void reset() = 0;
  // Solves qp; Solved, SolvedInaccurate (PIQP capped with small residuals) or the failure cause.
  // Adds its iterations to res; PIQP's retry is skipped once the step's time_limit has passed.
  virtual Status solve(const QpProblem& qp, const Settings& s, StepResult& res,
                       Clock::time_point t_start) = 0;
  // The last solve's primal solution and objective 1/2 w^T P w + q^T w (without QpProblem::constant).
  virtual const Eigen::VectorXd& w() const = 0;
  virtual double objective() const = 0;
  // The last solve's primal-dual solution (copies; allocates).
  virtual QpSolution solution() const = 0;
};

// PIQP, set up on the QP's pattern; no warm start.
class PiqpBackend final : public QpBackend {
 public:
  PiqpBackend(const QpProblem& qp, const Settings& s);
  void begin_step(int, const QpBackend&) override {}
  const Eigen::VectorXi* final_set(int) const override { return nullptr; }
  void plan_applied(int) override {}
  void reset() override {}
  Status solve(const QpProblem& qp, const Settings& s, StepResult& res, Clock::time_point t_start) override;
  const Eigen::VectorXd& w() const override { return solver_.result().x; }
  double objective() const override { return solver_.result().info.primal_obj; }
  QpSolution solution() const override;
  const piqp::Result<double>& result() const { return solver_.result(); }

 private:
  piqp::SparseSolver<double> solver_;
};

// The active set warm-started from the last QP's set (the previous step's shifted by one node in a
// step's first QP, from the QP of one node more in the shrinking phase); once more from the empty set
// if that guess fails (a wrong guess can make dependent rows active); PIQP if neither verifies, whose
// multipliers then give the next guess.
class ActiveSetBackend final : public QpBackend {
 public:
  // `longer`: the layout of the QP of one node more whose set may warm-start this one (nullptr: none).
  ActiveSetBackend(const QpProblem& qp, const QpLayout& layout, const QpLayout* longer, const Settings& s);
  void begin_step(int k, const QpBackend& previous) override;
  const Eigen::VectorXi* final_set(int k) const override { return k >= 0 && set_k_ == k ? &set_ : nullptr; }
  void plan_applied(int k) override { set_k_ = k; }
  void reset() override { set_k_ = -1; }
  Status solve(const QpProblem& qp, const Settings& s, StepResult& res, Clock::time_point t_start) override;
  const Eigen::VectorXd& w() const override { return by_active_set_ ? active_set_.w() : piqp_.w(); }
  double objective() const override { return by_active_set_ ? active_set_.objective() : piqp_.objective(); }
  QpSolution solution() const override;

 private:
  void set_from_piqp();

  ActiveSetQp active_set_;
  PiqpBackend piqp_;
  Eigen::VectorXi set_, prev_, shift_;  // working set (G rows, then variables), its copy, the shift map
  Eigen::VectorXi shift_longer_;        // the shift map from the longer QP's set (empty: none)
  Eigen::Index longer_set_size_ = -1;   // that set's size (-1: no longer QP)
  int set_k_ = -1;                      // step whose final set set_ holds (-1: none)
  bool by_active_set_ = false;          // the last QP was solved by the active set
};

// The backend of Settings::qp_solver for the QP laid out by `layout` (`longer`: see ActiveSetBackend).
std::unique_ptr<QpBackend> make_qp_backend(const QpProblem& qp, const QpLayout& layout,
                                           const QpLayout* longer, const Settings& s);

}  // namespace tubempc::mpc::detail
