// Which frame of a file with several a reader takes (gel/import.hpp).
#include <fmt/format.h>

#include "gel/errors.hpp"
#include "gel/import.hpp"

namespace gel::importing {

std::uint64_t resolve_frame(const std::string& path, std::int64_t frame, std::uint64_t count) {
  if (count == 0) throw InvalidArgument("path", "'" + path + "' holds no frames");
  const std::int64_t frames = static_cast<std::int64_t>(count);
  const std::int64_t index = frame < 0 ? frames + frame : frame;
  if (index < 0 || index >= frames)
    throw InvalidArgument("frame", fmt::format("'{}' holds {} frame{} (0 to {}, or -1 to -{} from the end): there is no frame {}", path,
                                               count, count == 1 ? "" : "s", count - 1, count, frame));
  return static_cast<std::uint64_t>(index);
}

}  // namespace gel::importing
