#include "tubempc/nav/faults.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace tubempc::nav {

namespace {

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw std::invalid_argument("faults." + field + ": " + why);
}

// Regularised lower incomplete gamma P(a, x) by its series (x < a + 1).
double gamma_p_series(double a, double x) {
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < 100000; ++n) {
    term *= x / (a + n);
    sum += term;
    if (std::abs(term) < std::abs(sum) * 1e-16) break;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

// Regularised upper incomplete gamma Q(a, x) by its continued fraction (x >= a + 1; modified Lentz).
double gamma_q_fraction(double a, double x) {
  constexpr double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-16) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

}  // namespace

const char* to_string(SensorFaultKind k) { return core::enum_name(k); }

const char* to_string(NavFault f) { return core::enum_name(f); }

void SensorFault::validate() const {
  if (!core::is_named(kind)) fail("kind", "not a sensor fault kind");
  if (!std::isfinite(t_start)) fail("start", "must be finite");
  if (!(duration > 0.0)) fail("duration", "must be > 0");
  if (!std::isfinite(magnitude)) fail("magnitude", "must be finite");
  if (!(axis_B.allFinite() && axis_B.norm() > 0.0)) fail("axis_B", "must be finite and non-zero");
}

void FaultDetectionSettings::validate() const {
  if (!(false_alarm_probability > 0.0 && false_alarm_probability < 1.0))
    fail("false_alarm_probability", "must be in (0, 1)");
  if (persistence < 1) fail("persistence", "must be >= 1");
  if (!(outage_time > 0.0)) fail("outage_time", "must be > 0");
  if (!(max_position_sigma > 0.0)) fail("max_position_sigma", "must be > 0");
}

double chi_square_upper_tail(double x, int dof) {
  if (dof < 1 || !(x >= 0.0)) throw std::invalid_argument("chi-square: dof must be >= 1 and x >= 0");
  if (x == 0.0) return 1.0;
  const double a = 0.5 * dof, y = 0.5 * x;
  if (std::isinf(y)) return 0.0;
  return y < a + 1.0 ? 1.0 - gamma_p_series(a, y) : gamma_q_fraction(a, y);
}

double chi_square_upper_quantile(double q, int dof) {
  if (!(q > 0.0 && q < 1.0)) throw std::invalid_argument("chi-square quantile: q must be in (0, 1)");
  if (dof < 1) throw std::invalid_argument("chi-square quantile: dof must be >= 1");
  double lo = 0.0, hi = dof + 10.0;
  while (chi_square_upper_tail(hi, dof) > q) hi *= 2.0;
  for (int i = 0; i < 400 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (chi_square_upper_tail(mid, dof) > q ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace tubempc::nav
