#pragma once
// The names QueryCurves filters on beside the resolved scene's fields.
namespace geld {

constexpr char kCacheKeyParameter[] = "run.cache_key";  // a parameter row
// The jobs table's program_version column (a parameter row before schema 7).
constexpr char kProgramVersionParameter[] = "run.program_version";

}  // namespace geld
