// Outcomes of the tube MPC: names of the statuses (their table: core::EnumNames<Status>, results.hpp).
#include "tubempc/mpc/results.hpp"

namespace tubempc::mpc {

std::string to_string(Status status) { return core::enum_name(status); }

}  // namespace tubempc::mpc
