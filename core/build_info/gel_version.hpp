#pragma once
// The one version string of every program of the project: release, git commit (with "-dirty"
// when the tree had uncommitted changes) and build type, e.g. "0.1.0 git 15d6cde1a2b3 Release".
#include <string>

namespace gel {
std::string program_version();
}  // namespace gel
