// The whole state of two systems compared bit for bit: positions, velocities, forces, bonds, the
// event counts and the energy ledger. The threads' tests run one system on T = 1 and the others
// on more threads or a change midway, and every bit must agree.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>

#include "gel/system.hpp"

namespace gel {

inline void expect_same_bits(const System& threaded, const System& serial) {
  EXPECT_EQ(threaded.x(), serial.x());
  EXPECT_EQ(threaded.y(), serial.y());
  EXPECT_EQ(threaded.vx(), serial.vx());
  EXPECT_EQ(threaded.vy(), serial.vy());
  EXPECT_EQ(threaded.omega(), serial.omega());
  EXPECT_EQ(threaded.fx(), serial.fx());
  EXPECT_EQ(threaded.fy(), serial.fy());
  EXPECT_EQ(threaded.torque(), serial.torque());
  ASSERT_EQ(threaded.bonds().size(), serial.bonds().size());
  for (std::size_t b = 0; b < serial.bonds().size(); ++b) {
    EXPECT_EQ(threaded.bonds()[b].i, serial.bonds()[b].i) << b;
    EXPECT_EQ(threaded.bonds()[b].j, serial.bonds()[b].j) << b;
    EXPECT_EQ(threaded.bonds()[b].bix, serial.bonds()[b].bix) << b;
    EXPECT_EQ(threaded.bonds()[b].biy, serial.bonds()[b].biy) << b;
    EXPECT_EQ(threaded.bonds()[b].bjx, serial.bonds()[b].bjx) << b;
    EXPECT_EQ(threaded.bonds()[b].bjy, serial.bonds()[b].bjy) << b;
  }
  EXPECT_EQ(threaded.events().normal, serial.events().normal);
  EXPECT_EQ(threaded.events().sliding, serial.events().sliding);
  EXPECT_EQ(threaded.events().rolling, serial.events().rolling);
  EXPECT_EQ(threaded.events().created, serial.events().created);
  EXPECT_EQ(threaded.energy().dissipated, serial.energy().dissipated);
  EXPECT_EQ(threaded.energy().created, serial.energy().created);
  EXPECT_EQ(threaded.energy().drag, serial.energy().drag);
  EXPECT_EQ(threaded.energy().wall_work, serial.energy().wall_work);
  EXPECT_EQ(threaded.wall_stress().p, serial.wall_stress().p);
}

}  // namespace gel
