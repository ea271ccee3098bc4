#pragma once
// The parameters geld records for QueryCurves beside the resolved scene's fields.
namespace geld {

constexpr char kCacheKeyParameter[] = "run.cache_key";
constexpr char kProgramVersionParameter[] = "run.program_version";

}  // namespace geld
