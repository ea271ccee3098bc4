#pragma once
// Shared by the integrator (integrator.cpp) and the FIRE relaxation (relax.cpp).

namespace gel {

// Rotation of (c, s) by a small angle alpha = omega dt. The speed guard keeps |alpha| <= 0.1
// (a|omega| <= 0.1 a/dt), where these series are exact to ~1e-16; std::cos/sin per particle
// per step would cost more than the whole rest of the integrator.
inline void rotate_small(double& c, double& s, double alpha) {
  const double a2 = alpha * alpha;
  const double cos_a = 1.0 - a2 * (0.5 - a2 * (1.0 / 24 - a2 * (1.0 / 720 - a2 * (1.0 / 40320))));
  const double sin_a = alpha * (1.0 - a2 * (1.0 / 6 - a2 * (1.0 / 120 - a2 * (1.0 / 5040 - a2 * (1.0 / 362880)))));
  const double c_new = c * cos_a - s * sin_a;
  const double s_new = s * cos_a + c * sin_a;
  // One Newton step towards |(c, s)| = 1 keeps the orientation a rotation.
  const double norm_fix = 1.5 - 0.5 * (c_new * c_new + s_new * s_new);
  c = c_new * norm_fix;
  s = s_new * norm_fix;
}

}  // namespace gel
