// Warm-started primal-dual active-set QP solver on a fixed-pattern KKT matrix (see active_set_qp.hpp).
#include "tubempc/mpc/active_set_qp.hpp"

#include <Eigen/OrderingMethods>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace tubempc::mpc {

std::string to_string(ActiveSetQp::Status status) { return core::enum_name(status); }

void ActiveSetQp::Settings::validate() const {
  auto fail = [](const char* field, const char* what) {
    throw std::invalid_argument(std::string("ActiveSetQp Settings: ") + field + " " + what);
  };
  if (max_iterations < 1) fail("max_iterations", "must be >= 1");
  if (primal_dual_iterations < 1) fail("primal_dual_iterations", "must be >= 1");
  if (!(eps_abs >= 0.0) || !(eps_rel >= 0.0) || !std::isfinite(eps_abs) || !std::isfinite(eps_rel) ||
      eps_abs + eps_rel <= 0.0)
    fail("eps_abs/eps_rel", "must be finite, >= 0 and not both 0");
  if (!(primal_reg > 0.0) || !std::isfinite(primal_reg)) fail("primal_reg", "must be finite and > 0");
  if (!(dual_reg > 0.0) || !std::isfinite(dual_reg)) fail("dual_reg", "must be finite and > 0");
  if (max_refinement < 0) fail("max_refinement", "must be >= 0");
  if (!(max_multiplier_ratio > 0.0)) fail("max_multiplier_ratio", "must be > 0 (inf disables it)");
}

void ActiveSetQp::setup(const SpMat& P_upper, const SpMat& A, const SpMat& G,
                        const Eigen::Array<bool, Eigen::Dynamic, 1>& boundable, const Settings& settings) {
  settings.validate();
  const int n = static_cast<int>(P_upper.rows());
  if (P_upper.cols() != n || A.cols() != n || G.cols() != n || boundable.size() != n)
    throw std::invalid_argument(
        "ActiveSetQp::setup: P must be n x n, A and G must have n columns, boundable n entries");
  if (!P_upper.isCompressed() || !A.isCompressed() || !G.isCompressed())
    throw std::invalid_argument("ActiveSetQp::setup: P, A and G must be compressed");
  settings_ = settings;
  n_ = n;
  m_ = static_cast<int>(A.rows());
  p_ = static_cast<int>(G.rows());
  const int nb = static_cast<int>(boundable.count());
  bound_var_.resize(nb);
  bound_row_.setConstant(n, -1);
  for (int j = 0, k = 0; j < n; ++j)
    if (boundable(j)) {
      bound_var_(k) = j;
      bound_row_(j) = k++;
    }
  const int nk = n + m_ + p_ + nb;
  penalty_row_.setConstant(p_, false);

  // Natural-order pattern (upper triangle): P, the diagonal, A^T, G^T and the bound rows.
  std::vector<Eigen::Triplet<double, int>> trip;
  trip.reserve(static_cast<std::size_t>(P_upper.nonZeros() + A.nonZeros() + G.nonZeros() + nb + nk));
  for (int c = 0; c < n; ++c)
    for (SpMat::InnerIterator it(P_upper, c); it; ++it) {
      if (it.row() > c)
        throw std::invalid_argument("ActiveSetQp::setup: P must be stored as its upper triangle");
      trip.emplace_back(it.row(), c, 1.0);
    }
  for (int c = 0; c < n; ++c) {
    for (SpMat::InnerIterator it(A, c); it; ++it) trip.emplace_back(c, n + it.row(), 1.0);
    for (SpMat::InnerIterator it(G, c); it; ++it) trip.emplace_back(c, n + m_ + it.row(), 1.0);
  }
  for (int k = 0; k < nb; ++k) trip.emplace_back(bound_var_(k), n + m_ + p_ + k, 1.0);
  for (int d = 0; d < nk; ++d) trip.emplace_back(d, d, 1.0);
  SpMat natural(nk, nk);
  natural.setFromTriplets(trip.begin(), trip.end());

  // Fill-reducing ordering of the symmetric pattern (as SimplicialLDLT's default would compute it).
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> amd_inv;
  Eigen::AMDOrdering<int>()(natural, amd_inv);
  const Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> amd = amd_inv.inverse();
  perm_ = amd.indices();

  for (auto& t : trip) {
    const int r = perm_(t.row()), c = perm_(t.col());
    t = Eigen::Triplet<double, int>(std::min(r, c), std::max(r, c), 0.0);
  }
  K_.resize(nk, nk);
  K_.setFromTriplets(trip.begin(), trip.end());
  K_.makeCompressed();
  const auto position = [&](int r, int c) {
    const int pr = std::min(perm_(r), perm_(c)), pc = std::max(perm_(r), perm_(c));
    const int* begin = K_.innerIndexPtr() + K_.outerIndexPtr()[pc];
    const int* end = K_.innerIndexPtr() + K_.outerIndexPtr()[pc + 1];
    const int* it = std::lower_bound(begin, end, pr);
    if (it == end || *it != pr) throw std::logic_error("ActiveSetQp: KKT pattern lookup failed");
    return static_cast<int>(it - K_.innerIndexPtr());
  };
  pos_P_.resize(P_upper.nonZeros());
  pos_A_.resize(A.nonZeros());
  pos_G_.resize(G.nonZeros());
  for (int c = 0, k = 0; c < n; ++c)
    for (SpMat::InnerIterator it(P_upper, c); it; ++it) pos_P_(k++) = position(static_cast<int>(it.row()), c);
  for (int c = 0, k = 0; c < n; ++c)
    for (SpMat::InnerIterator it(A, c); it; ++it) pos_A_(k++) = position(c, n + static_cast<int>(it.row()));
  for (int c = 0, k = 0; c < n; ++c)
    for (SpMat::InnerIterator it(G, c); it; ++it)
      pos_G_(k++) = position(c, n + m_ + static_cast<int>(it.row()));
  pos_B_.resize(nb);
  for (int k = 0; k < nb; ++k) pos_B_(k) = position(bound_var_(k), n + m_ + p_ + k);
  pos_diag_.resize(nk);
  for (int d = 0; d < nk; ++d) pos_diag_(d) = position(d, d);

  ldlt_.analyze(K_);
  K_factored_.setConstant(K_.nonZeros(), std::numeric_limits<double>::quiet_NaN());
  changed_.setZero(nk);
  reg_.setZero(nk);
  set_.setZero(p_ + n);
  rhs_.setZero(nk);
  sol_.setZero(nk);
  rhs_p_.setZero(nk);
  sol_p_.setZero(nk);
  res_p_.setZero(nk);
  tmp_.setZero(nk);
  corr_.setZero(nk);
  g_.setZero(p_);
  w_.setZero(n);
  y_.setZero(m_);
  z_l_.setZero(p_);
  z_u_.setZero(p_);
  z_bl_.setZero(n);
  z_bu_.setZero(n);
  lam_g_.setZero(p_);
  lam_b_.setZero(nb);
  w_c_.setZero(n);
  y_c_.setZero(m_);
  lam_gc_.setZero(p_);
  lam_bc_.setZero(nb);
  info_ = Info{};
}

void ActiveSetQp::write_matrix(const SpMat& P_upper, const SpMat& A, const SpMat& G,
                               const Eigen::VectorXi& active) {
  double* val = K_.valuePtr();
  std::fill(val, val + K_.nonZeros(), 0.0);
  const double* pv = P_upper.valuePtr();
  for (Eigen::Index k = 0; k < pos_P_.size(); ++k) val[pos_P_(k)] += pv[k];
  const double rho = settings_.primal_reg, delta = settings_.dual_reg;
  for (int j = 0; j < n_; ++j) {
    val[pos_diag_(j)] += rho;
    reg_(perm_(j)) = rho;
  }
  const double* av = A.valuePtr();
  for (Eigen::Index k = 0; k < pos_A_.size(); ++k) val[pos_A_(k)] += av[k];
  for (int i = 0; i < m_; ++i) {
    val[pos_diag_(n_ + i)] = -delta;
    reg_(perm_(n_ + i)) = -delta;
  }
  for (int c = 0, k = 0; c < n_; ++c)
    for (SpMat::InnerIterator it(G, c); it; ++it, ++k)
      if (active(it.row()) != 0) val[pos_G_(k)] += it.value();
  // Inactive rows keep -1 on the diagonal in K0 too (their multiplier is then 0).
  for (int i = 0; i < p_; ++i) {
    const bool on = active(i) != 0;
    val[pos_diag_(n_ + m_ + i)] = on ? -delta : -1.0;
    reg_(perm_(n_ + m_ + i)) = on ? -delta : 0.0;
  }
  for (Eigen::Index k = 0; k < bound_var_.size(); ++k) {
    const bool on = active(p_ + bound_var_(k)) != 0;
    const int d = n_ + m_ + p_ + static_cast<int>(k);
    val[pos_B_(k)] = on ? 1.0 : 0.0;
    val[pos_diag_(d)] = on ? -delta : -1.0;
    reg_(perm_(d)) = on ? -delta : 0.0;
  }
}

// Factorises K_, recomputing only the rows of the factor that depend on the columns whose values
// changed since the last factorisation (an active-set change touches a few columns).
bool ActiveSetQp::factorize() {
  const double* val = K_.valuePtr();
  double* old = K_factored_.data();
  const int* outer = K_.outerIndexPtr();
  int n_changed = 0;
  for (int c = 0; c < K_.cols(); ++c)
    if (!std::equal(val + outer[c], val + outer[c + 1], old + outer[c])) {
      changed_(n_changed++) = c;
      std::copy(val + outer[c], val + outer[c + 1], old + outer[c]);
    }
  return ldlt_.refactorize(K_, changed_.head(n_changed));
}

// res_p_ = rhs_p_ - K0 sol_p_ with K0 = K_ - diag(reg_) the unregularised KKT matrix (permuted order).
void ActiveSetQp::residual() {
  res_p_ = rhs_p_ + reg_.cwiseProduct(sol_p_);
  const int* Kp = K_.outerIndexPtr();
  const int* Ki = K_.innerIndexPtr();
  const double* Kx = K_.valuePtr();
  for (int c = 0; c < K_.cols(); ++c)
    for (int e = Kp[c]; e < Kp[c + 1]; ++e) {
      const int r = Ki[e];
      res_p_(r) -= Kx[e] * sol_p_(c);
      if (r != c) res_p_(c) -= Kx[e] * sol_p_(r);
    }
}

void ActiveSetQp::set_penalty_rows(const Eigen::Array<bool, Eigen::Dynamic, 1>& rows) {
  if (rows.size() != 0 && rows.size() != p_)
    throw std::invalid_argument("ActiveSetQp::set_penalty_rows: rows must have p entries (or none)");
  penalty_row_.setConstant(p_, false);
  if (rows.size() != 0) penalty_row_ = rows;
}

ActiveSetQp::Status ActiveSetQp::solve(const SpMat& P_upper, const Eigen::VectorXd& q, const SpMat& A,
                                       const Eigen::VectorXd& b, const SpMat& G, const Eigen::VectorXd& h_l,
                                       const Eigen::VectorXd& h_u, const Eigen::VectorXd& x_l,
                                       const Eigen::VectorXd& x_u, Eigen::Ref<Eigen::VectorXi> active) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const int n = n_, m = m_, p = p_;
  info_ = Info{};
  if (P_upper.rows() != n || P_upper.nonZeros() != pos_P_.size() || A.rows() != m ||
      A.nonZeros() != pos_A_.size() || G.rows() != p || G.nonZeros() != pos_G_.size() || q.size() != n ||
      b.size() != m || h_l.size() != p || h_u.size() != p || x_l.size() != n || x_u.size() != n ||
      active.size() != p + n)
    throw std::invalid_argument("ActiveSetQp::solve: sizes or patterns differ from setup");
  const auto finite_values = [](const SpMat& M) {
    return Eigen::Map<const Eigen::VectorXd>(M.valuePtr(), M.nonZeros()).allFinite();
  };
  bool valid = finite_values(P_upper) && finite_values(A) && finite_values(G) && q.allFinite() &&
               b.allFinite() && !h_l.array().isNaN().any() && !h_u.array().isNaN().any() &&
               !x_l.array().isNaN().any() && !x_u.array().isNaN().any() &&
               (h_l.array() <= h_u.array()).all() && (x_l.array() <= x_u.array()).all();
  for (int j = 0; j < n && valid; ++j) valid = bound_row_(j) >= 0 || (x_l(j) == -inf && x_u(j) == inf);
  if (!valid) return info_.status = Status::InvalidData;

  // The guess, restricted to sides that exist.
  for (int i = 0; i < p + n; ++i) {
    const double lo = i < p ? h_l(i) : x_l(i - p), up = i < p ? h_u(i) : x_u(i - p);
    const int a = i >= p && bound_row_(i - p) < 0 ? 0 : active(i);
    set_(i) = a > 0 && up < inf ? 1 : (a < 0 && lo > -inf ? -1 : 0);
  }

  const double q_norm = q.lpNorm<Eigen::Infinity>();
  // One factorisation of the KKT matrix of the current set and its solve (rhs_p_, sol_p_); false on a
  // zero pivot.
  const auto factor_and_solve = [&] {
    ++info_.iterations;
    write_matrix(P_upper, A, G, set_);
    if (!factorize()) return false;
    rhs_.head(n) = -q;
    rhs_.segment(n, m) = b;
    for (int i = 0; i < p; ++i) rhs_(n + m + i) = set_(i) > 0 ? h_u(i) : (set_(i) < 0 ? h_l(i) : 0.0);
    for (Eigen::Index k = 0; k < bound_var_.size(); ++k) {
      const int j = bound_var_(k), a = set_(p + j);
      rhs_(n + m + p + k) = a > 0 ? x_u(j) : (a < 0 ? x_l(j) : 0.0);
    }
    for (Eigen::Index i = 0; i < rhs_.size(); ++i) rhs_p_(perm_(i)) = rhs_(i);
    sol_p_ = rhs_p_;
    ldlt_.solve_in_place(sol_p_);
    return true;
  };
  // Iterative refinement against the unregularised matrix while the residual keeps shrinking, to
  // `tight` accuracy (a hundredth of the verification tolerance; the solution a final set returns) or,
  // while the set still changes, to the set updates' resolution (a hundredth of their tolerances
  // eps_abs + 1e-12 x scale); false on a non-finite residual. Stationarity rows scale with q (which
  // holds the L1 penalty weights, ~1e6), constraint rows with b and the bounds: each block is judged
  // against its own scale, or a 1e6 penalty would let the constraint rows keep residuals of ~1e-9,
  // which the large multipliers of the shrinking phase turn into objective errors of ~1e-5 relative.
  const auto refine = [&](bool tight) {
    const double dual_rhs = q_norm, primal_rhs = rhs_.tail(rhs_.size() - n).lpNorm<Eigen::Infinity>();
    double last = inf;
    const double tol = 1e-2 * settings_.eps_abs;
    for (int r = 0; r <= settings_.max_refinement; ++r) {
      residual();
      double dual_norm = 0.0, primal_norm = 0.0;
      for (int i = 0; i < n; ++i) dual_norm = std::max(dual_norm, std::abs(res_p_(perm_(i))));
      for (Eigen::Index i = n; i < rhs_.size(); ++i)
        primal_norm = std::max(primal_norm, std::abs(res_p_(perm_(i))));
      const double norm = std::max(dual_norm, primal_norm);
      if (!std::isfinite(norm)) return false;
      const bool accurate =
          tight ? dual_norm <= tol + 1e-15 * dual_rhs && primal_norm <= 1e-2 * tol + 1e-15 * primal_rhs
                : dual_norm <= tol + 1e-14 * dual_rhs && primal_norm <= tol + 1e-14 * primal_rhs;
      if (r == settings_.max_refinement || accurate || norm > 0.5 * last) break;
      last = norm;
      ldlt_.solve_in_place(res_p_);
      sol_p_ += res_p_;
      ++info_.refinements;
    }
    return true;
  };
  // The refined solution as (w_, y_, lam_g_, lam_b_, g_ = G w_); inactive rows' multipliers are 0.
  const auto extract = [&] {
    for (Eigen::Index i = 0; i < sol_.size(); ++i) sol_(i) = sol_p_(perm_(i));
    w_ = sol_.head(n);
    y_ = sol_.segment(n, m);
    for (int i = 0; i < p; ++i) lam_g_(i) = set_(i) != 0 ? sol_(n + m + i) : 0.0;
    for (Eigen::Index k = 0; k < bound_var_.size(); ++k)
      lam_b_(k) = set_(p + bound_var_(k)) != 0 ? sol_(n + m + p + k) : 0.0;
    g_.noalias() = G * w_;
  };
  const auto lo_of = [&](int i) { return i < p ? h_l(i) : x_l(i - p); };
  const auto up_of = [&](int i) { return i < p ? h_u(i) : x_u(i - p); };
  const auto value_of = [&](int i) { return i < p ? g_(i) : w_(i - p); };
  const auto lam_of = [&](int i) { return i < p ? lam_g_(i) : lam_b_(bound_row_(i - p)); };
  const auto tol_p = [&](double bound) { return settings_.eps_abs + settings_.eps_rel * std::abs(bound); };
  const auto tol_d = [&] {
    return settings_.eps_abs +
           1e-12 * std::max({q_norm, y_.lpNorm<Eigen::Infinity>(), lam_g_.lpNorm<Eigen::Infinity>(),
                             lam_b_.lpNorm<Eigen::Infinity>()});
  };
  // A row whose multiplier has the wrong sign for its side (rows with lo == up take either sign).
  const auto wrong_sign = [&](int i, double lam, double td) {
    if (lo_of(i) == up_of(i)) return false;
    return (set_(i) > 0 && lam < -td) || (set_(i) < 0 && lam > td);
  };
  // The most violated inactive row and its side (0: none beyond tol_p).
  const auto most_violated = [&](int& side) {
    int worst = -1;
    double worst_violation = 0.0;
    side = 0;
    for (int i = 0; i < p + n; ++i) {
      if (set_(i) != 0 || (i >= p && bound_row_(i - p) < 0)) continue;
      const double v = value_of(i), lo = lo_of(i), up = up_of(i);
      if (v > up + tol_p(up) && v - up > worst_violation) {
        worst = i;
        worst_violation = v - up;
        side = 1;
      } else if (v < lo - tol_p(lo) && lo - v > worst_violation) {
        worst = i;
        worst_violation = lo - v;
        side = -1;
      }
    }
    return worst;
  };

  // Phase 1, primal-dual active set: the first kFullUpdates iterations change every row whose
  // multiplier has the wrong sign or whose bound is violated (the primal-dual active-set step); later
  // ones only the worst wrong-sign multiplier and the worst violated row (this breaks the cycles the
  // full step can fall into when the Hessian is not an M-matrix; one of each, not one in all, halves the
  // iterations of a guess that is off by several rows of each kind). One full step: on the Bennu
  // mission's shrinking phase, further full steps add rows that make the set dependent. A set that the
  // loose solution leaves unchanged is checked again on the tight one before it counts as repeated.
  bool repeated = false;
  bool singular = false;
  while (info_.iterations < std::min(settings_.max_iterations, settings_.primal_dual_iterations)) {
    if (!factor_and_solve()) {
      singular = true;
      break;
    }
    bool changed = false;
    for (int pass = 0; pass < 2 && !changed && !singular; ++pass) {
      if (!refine(pass == 1)) {
        singular = true;
        break;
      }
      extract();
      // Dependent active rows: the regularised KKT matrix gives them multipliers of the order of
      // 1/dual_reg, and the set updates they drive lead the iteration astray.
      if (std::max(lam_g_.lpNorm<Eigen::Infinity>(), lam_b_.lpNorm<Eigen::Infinity>()) >
          settings_.max_multiplier_ratio * std::max(1.0, q_norm)) {
        singular = true;
        break;
      }
      const double td = tol_d();
      constexpr int kFullUpdates = 1;
      const bool full = info_.iterations <= kFullUpdates;
      int drop_row = -1, drop_to = 0, add_row = -1, add_to = 0;
      double worst_drop = 0.0, worst_add = 0.0;
      // Penalty rows stay while another row has a wrong sign (set_penalty_rows).
      bool keep_penalty_rows = false;
      for (int i = 0; i < p + n && !keep_penalty_rows; ++i)
        keep_penalty_rows = (i >= p || !penalty_row_(i)) && (i < p || bound_row_(i - p) >= 0) &&
                            set_(i) != 0 && wrong_sign(i, lam_of(i), td);
      for (int i = 0; i < p + n; ++i) {
        if (i >= p && bound_row_(i - p) < 0) continue;
        const int a = set_(i);
        if (keep_penalty_rows && i < p && penalty_row_(i) && a != 0) continue;
        const double value = value_of(i), lam = lam_of(i), lo = lo_of(i), up = up_of(i);
        int to = a;
        double score = 0.0;
        bool drop = false;
        if (a > 0 && lam < -td) {
          to = lo == up ? -1 : 0;
          score = -lam;
          drop = true;
        } else if (a < 0 && lam > td) {
          to = lo == up ? 1 : 0;
          score = lam;
          drop = true;
        } else if (a == 0 && value > up + tol_p(up)) {
          to = 1;
          score = value - up;
        } else if (a == 0 && value < lo - tol_p(lo)) {
          to = -1;
          score = lo - value;
        }
        if (to == a) continue;
        changed = true;
        if (full) {
          set_(i) = to;
        } else if (drop && score > worst_drop) {
          drop_row = i;
          drop_to = to;
          worst_drop = score;
        } else if (!drop && score > worst_add) {
          add_row = i;
          add_to = to;
          worst_add = score;
        }
      }
      if (drop_row >= 0) set_(drop_row) = drop_to;
      if (add_row >= 0) set_(add_row) = add_to;
    }
    if (singular) break;
    if (!changed) {
      repeated = true;
      break;
    }
  }

  // Phase 2, dual active set (Goldfarb and Idnani, Math. Program. 27, 1983), when the primal-dual
  // iteration did not settle within Settings::primal_dual_iterations or met a dependent set. From a
  // dual-feasible set (the current one without its wrong-sign rows; the empty set if that is singular),
  // add the most violated row c: the solutions of the equality-constrained QPs on W and on W + {c} are
  // joined by a segment of minimisers along which c's multiplier grows from 0; where an active row's
  // multiplier reaches 0 first, that row leaves W and the segment continues from there. The dual
  // objective increases at every step, so sets do not repeat (no cycling, unlike phase 1).
  if (!repeated && info_.iterations < settings_.max_iterations) {
    bool feasible = false;  // a dual-feasible set with its solution in (w_, ..., g_)
    while (!feasible && info_.iterations < settings_.max_iterations) {
      if (!factor_and_solve() || !refine(false)) {
        if ((set_.array() == 0).all()) return info_.status = Status::Singular;
        set_.setZero();
        continue;
      }
      extract();
      const double td = tol_d();
      feasible = true;
      for (int i = 0; i < p + n; ++i)
        if (set_(i) != 0 && wrong_sign(i, lam_of(i), td)) {
          set_(i) = 0;
          feasible = false;
        }
    }
    // The current point (the last solution, interpolated along the segment) in w_c_, y_c_, lam_c_.
    w_c_ = w_;
    y_c_ = y_;
    lam_gc_ = lam_g_;
    lam_bc_ = lam_b_;
    while (feasible && info_.iterations < settings_.max_iterations) {
      int side = 0;
      const int c = most_violated(side);
      if (c <
          0) {  // the current point solves the QP on the current set: refine it to the verification's accuracy
        if (!refine(true)) return info_.status = Status::Singular;
        extract();
        int side_tight = 0;
        if (most_violated(side_tight) < 0) {
          repeated = true;
          break;
        }
        continue;
      }
      set_(c) = side;
      bool added = false;
      while (!added && info_.iterations < settings_.max_iterations) {
        if (!factor_and_solve() || !refine(false)) return info_.status = Status::Singular;
        extract();
        // The first active row (other than c) whose multiplier changes sign along the segment.
        const double td = tol_d();
        double t_block = 1.0;
        int blocking = -1;
        for (int i = 0; i < p + n; ++i) {
          if (i == c || set_(i) == 0 || !wrong_sign(i, lam_of(i), td)) continue;
          const double now = i < p ? lam_gc_(i) : lam_bc_(bound_row_(i - p)), next = lam_of(i);
          const double t = now == next ? 0.0 : std::max(0.0, now / (now - next));
          if (t < t_block) {
            t_block = t;
            blocking = i;
          }
        }
        if (blocking < 0) {
          added = true;
          w_c_ = w_;
          y_c_ = y_;
          lam_gc_ = lam_g_;
          lam_bc_ = lam_b_;
          break;
        }
        w_c_ += t_block * (w_ - w_c_);
        y_c_ += t_block * (y_ - y_c_);
        lam_gc_ += t_block * (lam_g_ - lam_gc_);
        lam_bc_ += t_block * (lam_b_ - lam_bc_);
        set_(blocking) = 0;
        if (blocking < p)
          lam_gc_(blocking) = 0.0;
        else
          lam_bc_(bound_row_(blocking - p)) = 0.0;
      }
    }
  }

  // Solution in QpSolution's convention, and the KKT residuals of the unregularised problem.
  z_u_ = lam_g_.cwiseMax(0.0);
  z_l_ = (-lam_g_).cwiseMax(0.0);
  z_bu_.setZero();
  z_bl_.setZero();
  for (Eigen::Index k = 0; k < bound_var_.size(); ++k) {
    z_bu_(bound_var_(k)) = std::max(lam_b_(k), 0.0);
    z_bl_(bound_var_(k)) = std::max(-lam_b_(k), 0.0);
  }
  // Stationarity: tmp_ (first n entries) = P w + q + A^T y + G^T lam_g + lam_b.
  auto stat = tmp_.head(n);
  stat = q;
  double pw_norm = 0.0, aty_norm = 0.0, gtl_norm = 0.0;
  corr_.head(n).setZero();
  for (int c = 0; c < n; ++c)
    for (SpMat::InnerIterator it(P_upper, c); it; ++it) {
      corr_(it.row()) += it.value() * w_(c);
      if (it.row() != c) corr_(c) += it.value() * w_(it.row());
    }
  objective_ = 0.5 * w_.dot(corr_.head(n)) + q.dot(w_);
  pw_norm = corr_.head(n).lpNorm<Eigen::Infinity>();
  stat += corr_.head(n);
  corr_.head(n).noalias() = A.transpose() * y_;
  aty_norm = corr_.head(n).lpNorm<Eigen::Infinity>();
  stat += corr_.head(n);
  corr_.head(n).noalias() = G.transpose() * lam_g_;
  gtl_norm = corr_.head(n).lpNorm<Eigen::Infinity>();
  stat += corr_.head(n);
  stat += z_bu_ - z_bl_;
  info_.dual_res = stat.lpNorm<Eigen::Infinity>();
  corr_.head(m).noalias() = A * w_;
  double primal = (corr_.head(m) - b).lpNorm<Eigen::Infinity>();
  double primal_scale =
      std::max({b.lpNorm<Eigen::Infinity>(), w_.lpNorm<Eigen::Infinity>(), g_.lpNorm<Eigen::Infinity>()});
  for (int i = 0; i < p; ++i) primal = std::max({primal, g_(i) - h_u(i), h_l(i) - g_(i)});
  for (int j = 0; j < n; ++j) primal = std::max({primal, w_(j) - x_u(j), x_l(j) - w_(j)});
  info_.primal_res = primal;
  info_.n_active = static_cast<int>((set_.array() != 0).count());
  active = set_;
  const double dual_scale = std::max({pw_norm, q_norm, aty_norm, gtl_norm, lam_b_.lpNorm<Eigen::Infinity>()});
  if (!repeated) return info_.status = Status::MaxIterations;
  const bool accurate = std::isfinite(primal) && std::isfinite(info_.dual_res) &&
                        primal <= settings_.eps_abs + settings_.eps_rel * primal_scale &&
                        info_.dual_res <= settings_.eps_abs + settings_.eps_rel * dual_scale;
  return info_.status = accurate ? Status::Solved : Status::Inaccurate;
}

}  // namespace tubempc::mpc
