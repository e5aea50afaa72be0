// The tube MPC's linearisation trajectory and per-node model data (not installed), with their re-use
// across steps and SCP iterations (Settings::linearization, tube_mpc.hpp).
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "sparse_blocks.hpp"
#include "tubempc/math/linearized_model.hpp"
#include "tubempc/mpc/results.hpp"
#include "tubempc/mpc/tube_mpc.hpp"

namespace tubempc::mpc::detail {

struct LinearizationCache {
  Eigen::MatrixXd z_lin, v_lin;  // linearisation trajectory: nx x (N + 1), nu x N
  std::vector<Eigen::MatrixXd> Ad, Bd, Gc;
  std::vector<Eigen::VectorXd> cd, hc;
  // Trajectory of the model data in Ad..hc, and (after a converged step) the step whose data they are
  // (lin_k, -1: none) with its horizon lin_n: Ad..cd hold nodes 0..lin_n-1, Gc, hc nodes 0..lin_n.
  Eigen::MatrixXd z_lin_at, v_lin_at;
  // The state about which each node's data were last computed whole (nx x N): the point a kept part of them
  // (LinearizedModel::rediscretize) belongs to, handed to the next re-discretisation as its x_prev, so that a
  // model's tolerance is measured from there, not from the last point (small moves would add up).
  Eigen::MatrixXd z_anchor;
  int lin_k = -1, lin_n = 0;
  // Nodes whose discretisation (N) and constraints (N + 1) the next evaluate() computes.
  Eigen::Array<bool, Eigen::Dynamic, 1> eval_d, eval_c;

  void allocate(int nx, int nu, int nc, int N);
  // Model data about the reference at every node j of the mission (t0 + j dt), kept for the steps: a node
  // evaluated afresh re-discretises from the reference's data at its time (LinearizedModel::rediscretize keeps
  // what does not depend on the difference, e.g. the gravity's blocks within their position tolerance). Also
  // the data of a first step at k = 0 in the form a converged step at k = -1 would leave them, so that it
  // evaluates only its last node. ref: the mission reference (T + 1 and T columns), which the later calls
  // are handed again.
  void prime(const math::LinearizedModel& model, const Reference& ref, double dt);
  // The model's discretisation at the mission's node j about (x, u): re-discretised from prime()'s reference
  // data at j where there are some, else `discretize` (TubeMPC::discretize, a new node in evaluate). Returns
  // whether a part of the reference's data was kept.
  bool discretize_at(const math::LinearizedModel& model, const Reference& ref, int j, double dt,
                     const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                     Eigen::Ref<Eigen::MatrixXd> A, Eigen::Ref<Eigen::MatrixXd> B,
                     Eigen::Ref<Eigen::VectorXd> c) const;
  // Start of step k with horizon n: with `reuse` after a converged step at k - 1, that step's model
  // data and their points (z_lin_at, v_lin_at) shifted by one node. Sets the nodes to evaluate: the
  // new ones and, shifted with them, those that step's last QP moved by scp_eps or more (ScpMode::
  // RealTime; none after a step that converged); returns the re-used nodes' counts (discretisations
  // n_reuse_d, states and constraints n_reuse_z).
  void begin_step(int k, int n, bool reuse, int& n_reuse_d, int& n_reuse_z);
  // Evaluates the marked nodes of the horizon n about (z_lin, v_lin) (node i at time t0 + (k + i) dt;
  // `rediscretize` where the node holds data about (z_lin_at, v_lin_at) for the same time: after the
  // first SCP iteration, and for re-used nodes); NumericalError on non-finite data, ModelStructure on a
  // nonzero outside the masks.
  Status evaluate(const math::LinearizedModel& model, const Reference& ref, int k, double dt, int n, int it,
                  const Mask& mA, const Mask& mB, const Mask& mG, int& model_evaluations);
  // Whether the model data equal the previous QP's (only for it > 0 with an inactive trust region);
  // otherwise keeps them for the next comparison.
  bool same_as_last(int it, int n, bool trust_region_inactive);
  // The QP's plan (z_star, v_star): with `reuse`, a node that moved less than scp_eps keeps its data
  // and point, the others take the plan as their next linearisation point.
  void update(const Eigen::MatrixXd& z_star, const Eigen::MatrixXd& v_star, int n, bool reuse,
              double scp_eps);
  // Step k with horizon n converged (or ran its one QP, `keep_moved`: ScpMode::RealTime): its data
  // may be re-used by step k + 1, which re-evaluates the nodes the last update() marked as moved only
  // with `keep_moved`.
  void converged(int k, int n, bool keep_moved) {
    lin_k = k;
    lin_n = n;
    if (!keep_moved) {
      eval_d.setConstant(false);
      eval_c.setConstant(false);
    }
  }
  void reset() {
    lin_k = -1;
    primed_ = false;
  }

 private:
  int nc_ = 0;           // state constraints per node
  int n_reused_d_ = 0;   // nodes 0..n_reused_d_-1 hold discretisations about z_lin_at for this step's times
  bool primed_ = false;  // the data are prime()'s (for k = 0)
  // prime()'s model data about the reference, node j at t0 + j dt (finite ones flagged in ref_ok_)
  std::vector<Eigen::MatrixXd> Ad_ref_, Bd_ref_;
  std::vector<Eigen::VectorXd> cd_ref_;
  Eigen::Array<bool, Eigen::Dynamic, 1> ref_ok_;
  std::vector<Eigen::MatrixXd> Ad_prev_, Bd_prev_, Gc_prev_;
  std::vector<Eigen::VectorXd> cd_prev_, hc_prev_;
};

}  // namespace tubempc::mpc::detail
