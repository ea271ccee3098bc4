#include "gel_version.hpp"

#include "gel_build_info.h"

namespace gel {

std::string program_version() {
#ifdef GEL_VERSION
  return std::string(GEL_VERSION) + " git " + GEL_GIT_COMMIT + " " + GEL_BUILD_FLAVOUR;
#else
  return std::string("dev git ") + GEL_GIT_COMMIT + " " + GEL_BUILD_FLAVOUR;
#endif
}

}  // namespace gel
