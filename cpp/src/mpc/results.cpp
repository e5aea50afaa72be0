// Outcomes of the tube MPC: names of the statuses (see results.hpp).
#include "tubempc/mpc/results.hpp"

namespace tubempc::mpc {

std::string to_string(Status status) {
  switch (status) {
    case Status::Solved:
      return "solved";
    case Status::SolvedInaccurate:
      return "solved_inaccurate";
    case Status::MaxIterations:
      return "max_iterations";
    case Status::FallbackShiftedPlan:
      return "fallback_shifted_plan";
    case Status::FallbackSafeInput:
      return "fallback_safe_input";
    case Status::Infeasible:
      return "infeasible";
    case Status::NotSolved:
      return "not_solved";
    case Status::TimeLimit:
      return "time_limit";
    case Status::NumericalError:
      return "numerical_error";
    case Status::EmptyTightening:
      return "empty_tightening";
    case Status::ModelStructure:
      return "model_structure";
  }
  return "unknown";
}

}  // namespace tubempc::mpc
