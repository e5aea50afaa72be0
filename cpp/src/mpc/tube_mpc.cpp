// Tube MPC nominal problem: the SCP loop over a fixed-pattern sparse QP, and the fallbacks (see
// tube_mpc.hpp). The pieces: the QP's layout and pattern (qp_layout.hpp), its solver (qp_backend.hpp),
// the linearisation data (linearization_cache.hpp); the settings' validation is in settings.cpp.
#include "tubempc/mpc/tube_mpc.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "linearization_cache.hpp"
#include "qp_backend.hpp"
#include "qp_layout.hpp"
#include "sparse_blocks.hpp"

namespace tubempc::mpc {

using detail::Clock;
using detail::kInf;
using detail::seconds_since;
using detail::write_block;
using detail::zero_block;
using detail::zero_block_row;

Eigen::MatrixXd solve_dare(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::MatrixXd& Q,
                           const Eigen::MatrixXd& R, double tol, int max_iterations) {
  const Eigen::Index n = A.rows();
  if (A.cols() != n || B.rows() != n || Q.rows() != n || Q.cols() != n || R.rows() != B.cols() ||
      R.cols() != B.cols())
    throw std::invalid_argument("solve_dare: inconsistent sizes of A, B, Q, R");
  if (!A.allFinite() || !B.allFinite() || !Q.allFinite() || !R.allFinite())
    throw std::invalid_argument("solve_dare: non-finite entries in A, B, Q or R");
  Eigen::LLT<Eigen::MatrixXd> llt_R(R);
  if (llt_R.info() != Eigen::Success) throw std::invalid_argument("solve_dare: R is not positive definite");
  // Structured doubling (Chu, Fan, Lin 2005): A_k, G_k, H_k with H_k -> X quadratically.
  Eigen::MatrixXd Ak = A;
  Eigen::MatrixXd Gk = B * llt_R.solve(B.transpose());
  Eigen::MatrixXd Hk = Q;
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
  for (int it = 0; it < max_iterations; ++it) {
    Eigen::PartialPivLU<Eigen::MatrixXd> lu(I + Gk * Hk);
    if (!(std::abs(lu.determinant()) > 0.0) || !std::isfinite(lu.determinant()))
      throw std::runtime_error("solve_dare: singular I + G H in the doubling iteration " +
                               std::to_string(it));
    const Eigen::MatrixXd W1 = lu.solve(Ak);  // (I + G H)^-1 A
    const Eigen::MatrixXd W2 = lu.solve(Gk);  // (I + G H)^-1 G
    const Eigen::MatrixXd H_next = Hk + Ak.transpose() * Hk * W1;
    Gk = Gk + Ak * W2 * Ak.transpose();
    Ak = Ak * W1;
    const double change = (H_next - Hk).cwiseAbs().maxCoeff();
    Hk = 0.5 * (H_next + H_next.transpose());
    if (!Hk.allFinite()) throw std::runtime_error("solve_dare: non-finite iterate");
    if (change <= tol * std::max(1.0, Hk.cwiseAbs().maxCoeff())) return Hk;
  }
  throw std::runtime_error("solve_dare: no convergence in " + std::to_string(max_iterations) +
                           " doubling iterations (is (A, B) stabilisable and (A, Q^1/2) detectable?)");
}

struct TubeMPC::Impl {
  int nx = 0, nu = 0, nc = 0, N = 0, T = 0;
  Eigen::MatrixXd Q, R, P_term;
  Reference ref;

  // The QP of horizon n = 1..N in slots[n - 1]: every step before the shrinking phase solves
  // horizon N, the shrinking phase's step k horizon T - k, each on its own fixed pattern and solver
  // (Settings::qp_solver) set up once.
  struct QpSlot {
    detail::QpLayout lay;
    detail::QpPattern pat;
    std::unique_ptr<detail::QpBackend> solver;
  };
  std::vector<QpSlot> slots;
  int current = 0;  // horizon of the last QP built (0: none)
  QpSlot& slot(int n) { return slots[static_cast<std::size_t>(n - 1)]; }
  const QpSlot& slot(int n) const { return slots[static_cast<std::size_t>(n - 1)]; }
  detail::LinearizationCache lin;

  bool have_plan = false;
  int plan_k = 0;                  // time index of z_plan's first node
  Eigen::MatrixXd z_plan, v_plan;  // last applied plan (for the shifted fallback)
  Eigen::MatrixXd z_ref;           // zbar_{min(k+i, T)}, i = 0..N: origin of the QP's state deviations
  Eigen::MatrixXd z_star, v_star;  // the last QP's plan

  // Tube work.
  Eigen::LLT<Eigen::MatrixXd> llt;
  Eigen::MatrixXd Lc;
  Eigen::VectorXd tmp_nx, tmp_nu, u_tight, e;

  StepResult result;

  void allocate(int nx_, int nu_, int nc_, const Settings& s) {
    nx = nx_;
    nu = nu_;
    nc = nc_;
    N = s.horizon;
    lin.allocate(nx, nu, nc, N);
    z_plan.setZero(nx, N + 1);
    v_plan.setZero(nu, N);
    z_star = z_plan;
    z_ref = z_plan;
    v_star = v_plan;
    llt.compute(Eigen::MatrixXd::Identity(nx, nx));  // sizes the factor storage (and sets its state) at setup
    Lc.setZero(nx, nx);
    tmp_nx.setZero(nx);
    tmp_nu.setZero(nu);
    e.setZero(nx);
    u_tight.setZero(nu);
    result.u.setZero(nu);
    result.z.setZero(nx, N + 1);
    result.v.setZero(nu, N);
  }
};

TubeMPC::TubeMPC(std::shared_ptr<const math::LinearizedModel> model, Settings settings)
    : model_(std::move(model)), settings_(std::move(settings)), impl_(std::make_unique<Impl>()) {
  if (!model_) throw std::invalid_argument("TubeMPC: model is null");
  const int nx = model_->nx(), nu = model_->nu();
  settings_.validate(nx, nu);
  if (model_->n_constraints() < 0) throw std::invalid_argument("TubeMPC: model n_constraints() < 0");
  if (settings_.G_structure.size() != 0 && settings_.G_structure.rows() != model_->n_constraints())
    throw std::invalid_argument("TubeMPC Settings: G_structure must have n_constraints() rows");
  if (settings_.Q.size() == 0) settings_.Q = Eigen::MatrixXd::Identity(nx, nx);
  if (settings_.R.size() == 0) settings_.R = Eigen::MatrixXd::Identity(nu, nu);
}

TubeMPC::~TubeMPC() = default;

const Eigen::MatrixXd& TubeMPC::terminal_weight() const { return impl_->P_term; }
int TubeMPC::mission_steps() const { return impl_->T; }
Eigen::Vector3i TubeMPC::qp_dimensions() const {
  const detail::QpLayout& l = impl_->slot(impl_->N).lay;
  return {l.n_var, l.n_eq, l.n_in};
}

void TubeMPC::setup(const Reference& reference) {
  const int nx = model_->nx(), nu = model_->nu();
  if (reference.u.cols() < 1 || reference.z.rows() != nx || reference.u.rows() != nu ||
      reference.z.cols() != reference.u.cols() + 1)
    throw std::invalid_argument(
        "TubeMPC::setup: reference.z must be n_x x (T + 1) and reference.u n_u x T, T >= 1");
  const int T = static_cast<int>(reference.u.cols());
  Eigen::MatrixXd A(nx, nx), B(nx, nu);
  Eigen::VectorXd c(nx);
  model_->discretize(reference.t0 + T * settings_.dt, settings_.dt, reference.z.col(T),
                     reference.u.col(T - 1), A, B, c);
  setup(reference, A, B);
}

void TubeMPC::setup(const Reference& reference, const Eigen::MatrixXd& A_terminal,
                    const Eigen::MatrixXd& B_terminal) {
  const int nx = model_->nx(), nu = model_->nu(), nc = model_->n_constraints();
  if (reference.u.cols() < 1 || reference.z.rows() != nx || reference.u.rows() != nu ||
      reference.z.cols() != reference.u.cols() + 1)
    throw std::invalid_argument(
        "TubeMPC::setup: reference.z must be n_x x (T + 1) and reference.u n_u x T, T >= 1");
  if (!reference.z.allFinite() || !reference.u.allFinite() || !std::isfinite(reference.t0))
    throw std::invalid_argument("TubeMPC::setup: reference has non-finite entries");
  if (A_terminal.rows() != nx || A_terminal.cols() != nx || B_terminal.rows() != nx ||
      B_terminal.cols() != nu)
    throw std::invalid_argument("TubeMPC::setup: A_terminal must be n_x x n_x and B_terminal n_x x n_u");
  impl_ = std::make_unique<Impl>();
  Impl& m = *impl_;
  m.Q = settings_.Q;
  m.R = settings_.R;
  m.P_term =
      solve_dare(A_terminal, B_terminal, m.Q, m.R, settings_.riccati_tol, settings_.riccati_max_iterations);
  m.ref = reference;
  m.T = static_cast<int>(reference.u.cols());
  m.allocate(nx, nu, nc, settings_);
  m.slots.resize(static_cast<std::size_t>(m.N));
  for (int n = m.N; n >= 1; --n) {  // from the longest: each shorter QP's warm start maps its set
    Impl::QpSlot& q = m.slot(n);
    q.lay = detail::QpLayout(nx, nu, nc, n, settings_);
    q.pat.build(q.lay, m.Q, m.R, m.P_term, settings_);
    q.solver = detail::make_qp_backend(q.pat.qp, q.lay, n < m.N ? &m.slot(n + 1).lay : nullptr, settings_);
  }
  if (settings_.linearization == Linearization::Reuse) m.lin.prime(*model_, m.ref, settings_.dt);
}

void TubeMPC::discretize(int k, const Eigen::Ref<const Eigen::VectorXd>& x,
                         const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::Ref<Eigen::MatrixXd> A,
                         Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const {
  const Impl& m = *impl_;
  if (k < 0 || k >= m.T)
    throw std::invalid_argument("TubeMPC::discretize: k = " + std::to_string(k) + " outside [0, " +
                                std::to_string(m.T) + ") (call setup first)");
  m.lin.discretize_at(*model_, m.ref, k, settings_.dt, x, u, A, B, c);
}

void TubeMPC::reset() {
  impl_->have_plan = false;
  impl_->lin.reset();
  for (auto& q : impl_->slots) q.solver->reset();
}

QpData TubeMPC::qp_data() const {
  QpData d;
  if (impl_->current == 0) return d;
  const detail::QpProblem& qp = impl_->slot(impl_->current).pat.qp;
  const detail::SpMat Pu = qp.P;
  d.P = Pu.selfadjointView<Eigen::Upper>();
  d.q = qp.q;
  d.A = qp.A;
  d.b = qp.b;
  d.G = qp.G;
  d.h_l = qp.h_l;
  d.h_u = qp.h_u;
  d.x_l = qp.x_l;
  d.x_u = qp.x_u;
  d.constant = qp.constant;
  return d;
}

QpSolution TubeMPC::qp_solution() const {
  if (impl_->current == 0) return QpSolution{};
  return impl_->slot(impl_->current).solver->solution();
}

// The phases of TubeMPC::step, in order; each works on the controller's preallocated state (Impl) and
// the step's constants (StepContext). None allocates after setup (tests/cpp/mpc_alloc).
struct TubeMPC::StepContext {
  const Settings& s;
  const math::LinearizedModel& model;
  const Eigen::Ref<const Eigen::VectorXd>& x_k;
  const Tube& tube;
  Clock::time_point t_start;
  int k = 0;
  int n = 0;  // nodes of this step's horizon, min(N, T - k)
  bool terminal_phase = false;
  int shift = 0;          // steps since the last plan
  bool use_plan = false;  // that plan seeds the linearisation (and the shifted fallback)
  int n_reuse_d = 0;      // nodes whose discretisation is re-used from the previous step
  int n_reuse_z = 0;      // nodes whose linearisation state and constraints are re-used
};

// Phase 1: re-use the previous converged step's model data shifted by one node
// (Settings::linearization) and let the QP solver warm-start from the previous step's (whose QP had
// this step's horizon or, in the shrinking phase, one node more).
void TubeMPC::shift_warm_start(StepContext& c) {
  Impl& m = *impl_;
  m.lin.begin_step(c.k, c.n, c.s.linearization == Linearization::Reuse, c.n_reuse_d, c.n_reuse_z);
  const int n_prev = std::min(m.N, m.T - c.k + 1);
  m.slot(c.n).solver->begin_step(c.k, *m.slot(n_prev).solver);
  m.current = c.n;
}

// Phase 2: the linearisation trajectory: the previous plan shifted to k (usually by one node),
// completed from the reference; the reference alone without a usable plan. Nodes with re-used data
// take the trajectory those data were computed about, unless the last QP moved them (ScpMode::RealTime).
void TubeMPC::seed_linearization(StepContext& c) {
  Impl& m = *impl_;
  const int N = m.N, T = m.T, k = c.k;
  c.shift = k - m.plan_k;
  c.use_plan = m.have_plan && c.shift >= 0 && c.shift < N;
  for (int i = 0; i <= N; ++i) {
    if (i < c.n_reuse_z && !m.lin.eval_c(i))
      m.lin.z_lin.col(i) = m.lin.z_lin_at.col(i);
    else
      m.lin.z_lin.col(i) =
          c.use_plan && i + c.shift <= N ? m.z_plan.col(i + c.shift) : m.ref.z.col(std::min(k + i, T));
  }
  for (int i = 0; i < N; ++i) {
    if (i < c.n_reuse_d && !m.lin.eval_d(i))
      m.lin.v_lin.col(i) = m.lin.v_lin_at.col(i);
    else
      m.lin.v_lin.col(i) =
          c.use_plan && i + c.shift < N ? m.v_plan.col(i + c.shift) : m.ref.u.col(std::min(k + i, T - 1));
  }
}

// The step's outcome when no new plan is applied: Theorem 1's candidate (the previous plan shifted to
// k, holding its last state, zero inputs appended (u_ref with InputCost::Deviation)) or the
// reference; the ancillary law on it, saturated and never non-finite.
const StepResult& TubeMPC::fallback(const StepContext& c, Status cause) {
  Impl& m = *impl_;
  StepResult& res = m.result;
  const Settings& s = c.s;
  const int N = m.N, T = m.T, k = c.k;
  res.failure = cause;
  if (c.use_plan && m.z_plan.allFinite() && m.v_plan.allFinite()) {
    for (int i = 0; i <= N; ++i) res.z.col(i) = m.z_plan.col(std::min(i + c.shift, N));
    for (int i = 0; i < N; ++i) {
      if (i + c.shift < N)
        res.v.col(i) = m.v_plan.col(i + c.shift);
      else if (s.input_cost == InputCost::Deviation && k + i < T)
        res.v.col(i) = m.ref.u.col(k + i);
      else
        res.v.col(i).setZero();
    }
    m.z_plan = res.z;
    m.v_plan = res.v;
    m.plan_k = k;
    res.status = Status::FallbackShiftedPlan;
  } else {
    for (int i = 0; i <= N; ++i) res.z.col(i) = m.ref.z.col(std::min(k + i, T));
    for (int i = 0; i < N; ++i) res.v.col(i) = m.ref.u.col(std::min(k + i, T - 1));
    res.status = Status::FallbackSafeInput;
  }
  m.e = c.x_k - res.z.col(0);
  res.u = res.v.col(0);
  if (c.tube.K.allFinite() && m.e.allFinite()) res.u.noalias() += c.tube.K * m.e;
  if (!res.u.allFinite()) res.u = m.ref.u.col(k);
  res.u = res.u.cwiseMax(-s.u_max).cwiseMin(s.u_max);
  res.objective = kInf;
  res.timings.total = seconds_since(c.t_start);
  return res;
}

// Phase 3: the tube's factor Pe = L L^T and the input tightenings sqrt(K_i Pe K_i^T).
Status TubeMPC::tighten(const StepContext& c) {
  Impl& m = *impl_;
  const Tube& tube = c.tube;
  if (!c.x_k.allFinite() || !tube.K.allFinite() || !tube.Pe.allFinite() || !tube.P_est.allFinite())
    return Status::NumericalError;
  m.llt.compute(tube.Pe);
  if (m.llt.info() != Eigen::Success) return Status::NumericalError;
  m.Lc = m.llt.matrixL();
  for (int j = 0; j < m.nu; ++j) {
    m.tmp_nx.noalias() = tube.Pe * tube.K.row(j).transpose();
    m.u_tight(j) = c.s.u_max(j) - std::sqrt(std::max(0.0, tube.K.row(j).dot(m.tmp_nx)));
  }
  return (m.u_tight.array() <= 0.0).any() ? Status::EmptyTightening : Status::Solved;
}

// Phase 4: the parts of the QP that do not depend on the linearisation: the initial condition, the
// input box and input cost, the state costs and the soft-constraint and soft-terminal rows. The
// QP's state variables are the deviations dz_i = z_i - zbar_{min(k+i, T)}: the objective then
// carries no large constant, which keeps the solvers' relative tolerances meaningful for states of
// hundreds of metres.
void TubeMPC::write_cost(const StepContext& c) {
  Impl& m = *impl_;
  const Settings& s = c.s;
  const int nx = m.nx, nu = m.nu, nc = m.nc, T = m.T, k = c.k, n = c.n;
  const detail::QpLayout& lay = m.slot(n).lay;
  detail::QpPattern& pat = m.slot(n).pat;
  detail::QpProblem& qp = pat.qp;
  for (int i = 0; i <= m.N; ++i) m.z_ref.col(i) = m.ref.z.col(std::min(k + i, T));
  qp.constant = 0.0;
  qp.b.head(nx) = c.x_k - m.z_ref.col(0);
  if (s.initial_condition == InitialCondition::WhitenedBox) {
    write_block(qp.A, pat.posA_L, m.Lc, -1.0, pat.mL);
    const double r = 1.0 / std::sqrt(static_cast<double>(nx));
    qp.x_l.segment(lay.off_s, nx).setConstant(-r);
    qp.x_u.segment(lay.off_s, nx).setConstant(r);
  }
  for (int i = 0; i < n; ++i) {
    qp.x_l.segment(lay.iv(i), nu) = -m.u_tight;
    qp.x_u.segment(lay.iv(i), nu) = m.u_tight;
    if (s.input_cost == InputCost::Deviation) {
      m.tmp_nu.noalias() = m.R * m.ref.u.col(k + i);
      qp.q.segment(lay.iv(i), nu) = -2.0 * m.tmp_nu;
      qp.constant += m.ref.u.col(k + i).dot(m.tmp_nu);
    } else {
      qp.q.segment(lay.iv(i), nu).setZero();
    }
  }
  for (int i = 0; i <= n; ++i) {
    const bool terminal_cost = i == n && !c.terminal_phase;
    const bool soft_end = i == n && c.terminal_phase && s.soft_terminal;
    // Stage, terminal (zbar_{k+N}, W = P_term) and soft-end (zbar_T = x_f, W = Q) costs are all
    // ||dz_i||^2_W. The soft end takes Q: the exact penalty already holds z_N at x_f, and P_term's
    // rate entries (~1e8) would only worsen the KKT conditioning there.
    if (i < n || terminal_cost || soft_end)
      write_block(qp.P, pat.posP_z[i], terminal_cost ? m.P_term : m.Q, 2.0, i < n ? pat.mQ : pat.mP);
    else
      zero_block(qp.P, pat.posP_z[i]);
    qp.q.segment(lay.iz(i), nx).setZero();
  }
  if (lay.off_sigma >= 0) {
    qp.q.segment(lay.off_sigma, (n + 1) * nc).setConstant(s.soft_penalty);
    qp.x_l.segment(lay.off_sigma, (n + 1) * nc).setZero();
  }
  if (lay.off_t >= 0) {
    const int r0 = lay.terminal_row();
    qp.q.segment(lay.off_t, nx).setConstant(c.terminal_phase ? s.soft_penalty : 0.0);
    qp.x_l.segment(lay.off_t, nx).setConstant(-kInf);  // t >= 0 follows from |dz_N| <= t: no redundant bound
    const double sign[4] = {1.0, -1.0, 1.0, 1.0};      // dz_N - t <= 0, dz_N + t >= 0 (zbar_T = x_f)
    for (int blk = 0; blk < 4; ++blk)
      for (int j = 0; j < nx; ++j)
        qp.G.valuePtr()[pat.posG_term[blk * nx + j]] = c.terminal_phase ? sign[blk] : 0.0;
    if (c.terminal_phase) {
      qp.h_l.segment(r0, nx).setConstant(-kInf);
      qp.h_u.segment(r0, nx).setZero();
      qp.h_l.segment(r0 + nx, nx).setZero();
      qp.h_u.segment(r0 + nx, nx).setConstant(kInf);
    } else {
      qp.h_l.segment(r0, 2 * nx).setConstant(-1.0);
      qp.h_u.segment(r0, 2 * nx).setConstant(1.0);
    }
  }
}

// Phase 5: the linearisation-dependent QP values: dynamics rows, tightened state constraints
// (sqrt(a^T Pe a)), the SCP trust region and the hard terminal equality.
void TubeMPC::write_constraints(const StepContext& c) {
  Impl& m = *impl_;
  const Settings& s = c.s;
  const Eigen::MatrixXd& Pe = c.tube.Pe;
  const int nx = m.nx, nc = m.nc, n = c.n;
  const detail::QpLayout& lay = m.slot(n).lay;
  detail::QpPattern& pat = m.slot(n).pat;
  detail::QpProblem& qp = pat.qp;
  for (int i = 0; i < n; ++i) {
    write_block(qp.A, pat.posA_A[i], m.lin.Ad[i], -1.0, pat.mA);
    write_block(qp.A, pat.posA_B[i], m.lin.Bd[i], -1.0, pat.mB);
    // dz_{i+1} - A dz_i - B v_i = c + A zbar_i - zbar_{i+1}
    m.tmp_nx.noalias() = m.lin.Ad[i] * m.z_ref.col(i);
    qp.b.segment(lay.dynamics_row(i), nx) = m.lin.cd[i] + m.tmp_nx - m.z_ref.col(i + 1);
  }
  for (int i = 0; i <= n && nc > 0; ++i) {
    write_block(qp.G, pat.posG[i], m.lin.Gc[i], 1.0, pat.mG);
    for (int j = 0; j < nc; ++j) {
      const int row = lay.state_row(i) + j;
      if (std::isfinite(m.lin.hc[i](j))) {
        double estimation = 0.0;  // output feedback: the estimation-error set's support (M40)
        if (c.tube.P_est.size() != 0) {
          m.tmp_nx.noalias() = c.tube.P_est * m.lin.Gc[i].row(j).transpose();
          estimation = std::sqrt(std::max(0.0, m.lin.Gc[i].row(j).dot(m.tmp_nx)));
        }
        m.tmp_nx.noalias() = Pe * m.lin.Gc[i].row(j).transpose();
        qp.h_l(row) = -kInf;
        qp.h_u(row) = m.lin.hc[i](j) - std::sqrt(std::max(0.0, m.lin.Gc[i].row(j).dot(m.tmp_nx))) -
                      estimation - m.lin.Gc[i].row(j).dot(m.z_ref.col(i));
      } else {  // the model marks the row absent
        zero_block_row(qp.G, pat.posG[i], pat.mG, j);
        qp.h_l(row) = -1.0;
        qp.h_u(row) = 1.0;
      }
    }
  }
  for (int i = 1; i <= n; ++i) {
    if (std::isfinite(s.trust_region)) {
      qp.x_l.segment(lay.iz(i), nx).array() = (m.lin.z_lin.col(i) - m.z_ref.col(i)).array() - s.trust_region;
      qp.x_u.segment(lay.iz(i), nx).array() = (m.lin.z_lin.col(i) - m.z_ref.col(i)).array() + s.trust_region;
    } else {
      qp.x_l.segment(lay.iz(i), nx).setConstant(-kInf);
      qp.x_u.segment(lay.iz(i), nx).setConstant(kInf);
    }
  }
  if (c.terminal_phase && !s.soft_terminal) {  // z_N = x_f = zbar_T
    qp.x_l.segment(lay.iz(n), nx).setZero();
    qp.x_u.segment(lay.iz(n), nx).setZero();
  }
}

// Phase 6: the QP's plan, its largest move from the linearisation (the SCP residual) and the next
// linearisation point. With Linearization::Reuse, a node whose plan moved less than scp_eps (it
// already meets the convergence test) keeps its model data and their point; the others are
// linearised about the new plan.
double TubeMPC::update_plan(const StepContext& c, const Eigen::VectorXd& x_qp) {
  Impl& m = *impl_;
  const Settings& s = c.s;
  const int nx = m.nx, nu = m.nu, N = m.N, n = c.n;
  const detail::QpLayout& lay = m.slot(n).lay;
  double delta = 0.0;
  for (int i = 0; i <= n; ++i) {
    m.z_star.col(i) = x_qp.segment(lay.iz(i), nx) + m.z_ref.col(i);
    delta = std::max(delta, (m.z_star.col(i) - m.lin.z_lin.col(i)).cwiseAbs().maxCoeff());
  }
  for (int i = n + 1; i <= N; ++i) m.z_star.col(i) = m.z_star.col(n);  // past the mission's end: z_T
  for (int i = 0; i < N; ++i) {
    if (i < n)
      m.v_star.col(i) = x_qp.segment(lay.iv(i), nu);
    else
      m.v_star.col(i).setZero();
  }
  m.lin.update(m.z_star, m.v_star, n, s.linearization == Linearization::Reuse, s.scp_eps);
  return delta;
}

// Phase 7: apply the plan: the ancillary law u = v_0 + K (x_k - z_0), saturated; keep the plan and
// (when converged) the model data for the next step.
const StepResult& TubeMPC::finish(const StepContext& c, bool converged, bool inaccurate) {
  Impl& m = *impl_;
  StepResult& res = m.result;
  res.z = m.z_star;
  res.v = m.v_star;
  m.z_plan = m.z_star;
  m.v_plan = m.v_star;
  m.have_plan = true;
  m.plan_k = c.k;
  m.e = c.x_k - res.z.col(0);
  res.u = res.v.col(0);
  res.u.noalias() += c.tube.K * m.e;
  res.u = res.u.cwiseMax(-c.s.u_max).cwiseMin(c.s.u_max);
  res.status = !converged ? Status::MaxIterations : (inaccurate ? Status::SolvedInaccurate : Status::Solved);
  if (!res.u.allFinite()) return fallback(c, Status::NumericalError);
  if (converged) m.lin.converged(c.k, c.n, c.s.scp_mode == ScpMode::RealTime);
  m.slot(c.n).solver->plan_applied(c.k);
  res.timings.total = seconds_since(c.t_start);
  return res;
}

const StepResult& TubeMPC::step(int k, const Eigen::Ref<const Eigen::VectorXd>& x_k, const Tube& tube) {
  Impl& m = *impl_;
  const Settings& s = settings_;
  if (m.T == 0) throw std::invalid_argument("TubeMPC::step: call setup first");
  if (k < 0 || k >= m.T) throw std::invalid_argument("TubeMPC::step: k must be in [0, T)");
  if (x_k.size() != m.nx) throw std::invalid_argument("TubeMPC::step: x_k must have n_x entries");
  if (tube.K.rows() != m.nu || tube.K.cols() != m.nx || tube.Pe.rows() != m.nx || tube.Pe.cols() != m.nx)
    throw std::invalid_argument("TubeMPC::step: tube.K must be n_u x n_x and tube.Pe n_x x n_x");
  if (tube.P_est.size() != 0 && (tube.P_est.rows() != m.nx || tube.P_est.cols() != m.nx))
    throw std::invalid_argument("TubeMPC::step: tube.P_est must be empty or n_x x n_x");

  StepContext c{s, *model_, x_k, tube, Clock::now()};
  c.k = k;
  c.n = std::min(m.N, m.T - k);
  c.terminal_phase = k >= m.T - m.N;
  StepResult& res = m.result;
  res.timings = Timings{};
  res.scp_iterations = 0;
  res.qp_iterations = 0;
  res.active_set_solves = 0;
  res.active_set_iterations = 0;
  res.active_set_failures = 0;
  res.active_set_refinements = 0;
  res.model_evaluations = 0;
  res.scp_residual = kInf;
  res.failure = Status::Solved;
  res.horizon = c.n;

  shift_warm_start(c);
  seed_linearization(c);
  if (const Status st = tighten(c); st != Status::Solved) return fallback(c, st);
  write_cost(c);

  // Sequential convex programming (Algorithm 1): linearise, write, solve, until the plan moves less
  // than scp_eps.
  bool converged = false;
  bool inaccurate = false;
  double last_delta = kInf;
  for (int it = 0; it < s.scp_max_iterations; ++it) {
    if (it > 0 && seconds_since(c.t_start) > s.time_limit) return fallback(c, Status::TimeLimit);
    auto t0 = Clock::now();
    const detail::QpPattern& pat = m.slot(m.N).pat;  // the masks are every horizon's
    const Status lin =
        m.lin.evaluate(c.model, m.ref, k, s.dt, c.n, it, pat.mA, pat.mB, pat.mG, res.model_evaluations);
    res.timings.linearize += seconds_since(t0);
    if (lin != Status::Solved) return fallback(c, lin);
    if (m.lin.same_as_last(it, c.n, last_delta < s.trust_region)) {
      res.scp_residual = 0.0;
      converged = true;
      break;
    }
    t0 = Clock::now();
    write_constraints(c);
    res.timings.build += seconds_since(t0);
    t0 = Clock::now();
    detail::QpBackend& solver = *m.slot(c.n).solver;
    const Status qp_status = solver.solve(m.slot(c.n).pat.qp, s, res, c.t_start);
    res.timings.solve += seconds_since(t0);
    res.scp_iterations = it + 1;
    if (qp_status == Status::SolvedInaccurate)
      inaccurate = true;
    else if (qp_status != Status::Solved)
      return fallback(c, qp_status);
    const Eigen::VectorXd& x_qp = solver.w();
    if (!x_qp.allFinite()) return fallback(c, Status::NumericalError);
    if (seconds_since(c.t_start) > s.time_limit) return fallback(c, Status::TimeLimit);
    const double delta = update_plan(c, x_qp);
    res.scp_residual = delta;
    last_delta = delta;
    res.objective = solver.objective() + m.slot(c.n).pat.qp.constant;
    // ScpMode::RealTime: one QP; the nodes it moved are re-linearised at the next step.
    if (delta < s.scp_eps || s.scp_mode == ScpMode::RealTime) {
      converged = true;
      break;
    }
  }
  return finish(c, converged, inaccurate);
}

}  // namespace tubempc::mpc
