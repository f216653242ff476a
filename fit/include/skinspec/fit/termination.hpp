#pragma once
// How a fit's solver ended (docs/solver.md): one of the stopping rules MINPACK and Ceres Solver
// define, named as Ceres names its options, or no convergence.

#include <optional>
#include <span>
#include <string_view>
#include <utility>

namespace skinspec {

enum class Termination {
  function_tolerance,       // a step changed the cost by less than its tolerance, relative to the cost
  gradient_tolerance,       // the largest component of the scaled gradient fell below its tolerance
  parameter_tolerance,      // the step was shorter than its tolerance, relative to the parameters
  min_trust_region_radius,  // every step was refused until the trust region had all but vanished
  iteration_limit,          // still improving when the solver ran out of iterations: not converged
  failed,                   // the start could not be evaluated: not converged
};

std::string_view to_string(Termination t);
std::optional<Termination> parse_termination(std::string_view name);
// Each termination and its name, in declaration order (for listings such as the API's schema).
std::span<const std::pair<Termination, std::string_view>> termination_names();
// True for the four stopping rules: the fit ended at a point it could not improve.
bool converged(Termination t);

}  // namespace skinspec
