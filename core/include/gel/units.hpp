#pragma once
// Reduced units of MODEL.md: a = F0 = m = 1. The constants are named so that the equations
// read like the specification.
namespace gel {
inline constexpr double kRadius = 1.0;                 // a
inline constexpr double kDiameter = 2.0 * kRadius;     // 2a, contact distance
inline constexpr double kMass = 1.0;                   // m
inline constexpr double kInertia = 0.4 * kMass * kRadius * kRadius;  // (2/5) m a^2
inline constexpr double kThickness = 2.0 * kRadius;    // box thickness when force -> stress
inline constexpr double kPi = 3.14159265358979323846;
}  // namespace gel
