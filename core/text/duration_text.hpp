#pragma once
// One way to write a duration in every program's progress line (gelsim, gelctl): "42s",
// "3m07s", "2h05m"; "?" when unknown (negative or not finite).
#include <cmath>
#include <cstdio>
#include <string>

namespace gel {

inline std::string duration_text(double seconds) {
  if (!(seconds >= 0) || !std::isfinite(seconds)) return "?";
  char text[32];
  const long whole = static_cast<long>(seconds);
  if (seconds < 60) {
    std::snprintf(text, sizeof text, "%lds", whole);
  } else if (seconds < 3600) {
    std::snprintf(text, sizeof text, "%ldm%02lds", whole / 60, whole % 60);
  } else {
    std::snprintf(text, sizeof text, "%ldh%02ldm", whole / 3600, (whole % 3600) / 60);
  }
  return text;
}

}  // namespace gel
