#pragma once
// The one curve table: column names with units, written by one writer for gelsim (curve.csv),
// gelctl (curve --csv) and read under the same names by the Python package (gel.curves).
#include <string>

#include "gel/v1/scene.pb.h"

namespace gel {

// Shortest decimal text that reads back to the same double.
std::string exact(double value);

// "k,phi [1],target_phi [1],P [F0/a^2],..." without a line end.
std::string curve_csv_header();
// One row under curve_csv_header(), without a line end.
std::string curve_csv_row(const gel::v1::CurveRow& row);
// Header and one line per row.
std::string curve_to_csv(const gel::v1::Curve& curve);
// profiles.csv: "k,phi [1],slice_0 [1],...,sigma_xx_0 [F0/a^2],...,sigma_yy_0 [F0/a^2],...,
// sigma_xy_0 [F0/a^2],..." one row per equilibrium, slices bottom to top: phi, then each stress
// component per slice (gel/virial_stress.hpp).
std::string profiles_to_csv(const gel::v1::Curve& curve);

}  // namespace gel
