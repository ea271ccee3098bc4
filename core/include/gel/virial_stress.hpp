#pragma once
// The stress tensor of the particles between the walls, from the virial of the bond forces
// (docs/compression.md "Stress tensor"). Computed on demand from the configuration (at the
// compression's rows only), never in the step loop.
//
// Convention: tension positive (the Cauchy stress), so a compressed network has sigma_yy < 0
// and at force balance sigma_yy = -(P_top + P_bot)/2. In the units of P, F0/a^2: a 2D force
// per length over the box thickness 2a (MODEL.md "Units").
//
//   sigma_ab = (1/V) [ sum_bonds r_ij,a F_ij,b  +  sum_(wall particle p, bond) (r_p - w_p)_a F_p,b ]
//
// with r_ij = r_j - r_i (minimum image), F_ij the bond's force on i (MODEL.md "Bonds":
// F_N n + F_T; on j it is -F_ij), V = 2a L_x (wall_top - wall_bottom) the volume that phi is
// measured in. The second sum treats the walls as the boundary: a particle stuck to a wall is
// held by the wall with the opposite of its bond forces, applied on the wall's plane at w_p =
// (x_p, wall_y). With it the identity
//   sigma_yy = -(P_top + P_bot)/2 - (1/V) sum_free (y_p - y_centre) F_p,y
// holds in any configuration (F_p the bond force on free particle p), so at force balance
// sigma_yy equals -P exactly. The kinetic part -(1/V) sum m v v is left out: at an equilibrium
// row it is bounded by 2 E_kin / V, many orders below P (tested).
//
// Per slice: each bond's (and wall link's) contribution is shared among the slices in
// proportion to the length of its segment (r_i to r_j, or r_p to the wall) inside each slice
// (Irving-Kirkwood / method of planes), so the slices average to the whole and, at force
// balance, every slice's sigma_yy equals -P.
#include <vector>

#include "gel/system.hpp"

namespace gel {

// sigma_ab = (1/V) sum r_a F_b [F0/a^2], all four components. xy and yx differ by the net
// couples: torques the walls hold and the O(delta/a) part of the bond torques.
struct StressTensor {
  double xx = 0, xy = 0, yx = 0, yy = 0;
  // The symmetric shear component, the sigma_xy a curve row reports.
  double shear() const { return 0.5 * (xy + yx); }
};

struct VirialStress {
  StressTensor total;
  // Equal slices between the walls, bottom to top (the slices of phi_profile), each over its
  // own volume. Without walls: of the periodic box, y from 0 to L_y.
  std::vector<StressTensor> slices;
};

// The stress of the configuration now, over `slices` slices (0: only the total).
VirialStress virial_stress(const System& system, int slices);

}  // namespace gel
