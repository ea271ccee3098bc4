#pragma once
// Protocol Buffers' JSON mapping writes 64-bit integers as strings ("seed": "3"), which every
// JSON reader then has to convert. The product's JSON (scenes, configurations, curves, gelctl's
// --json output) writes them as numbers instead; protobuf's JSON parser reads both forms, so
// files written this way still read back bit for bit.
#include <string>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <nlohmann/json.hpp>

namespace gel {

// The message in the JSON mapping with proto field names and every field printed, 64-bit
// integers as numbers. Throws std::runtime_error if protobuf cannot encode it.
nlohmann::json message_to_json(const google::protobuf::Message& message, bool print_defaults = true);

// What is wrong with a text as the JSON of a `type` message, in the product's words. Protobuf's
// own parser says "invalid value \"nan\" for type TYPE_DOUBLE" or "Unexpected token" and names
// no field, so a user of --set, --scene or a Python override cannot tell what to fix.
struct JsonProblem {
  // The dotted field ("compression.steps", "ensembles[1].scene.preset"); empty when the text
  // itself is not JSON or not an object.
  std::string field;
  std::string message;  // what is wrong and what the field takes; empty: nothing found
  explicit operator bool() const { return !message.empty(); }
};
// Checks names, JSON types, whole numbers and their ranges, finite numbers (the product has no
// use for NaN or infinity), enum names and oneofs. What it lets through protobuf still parses.
JsonProblem json_problem(const std::string& text, const google::protobuf::Descriptor& type);

// Why `dotted` ("generator.lx") names no value of a `type` message (a field that is not itself
// a message), or "" when it does.
std::string field_path_problem(const google::protobuf::Descriptor& type, const std::string& dotted);

}  // namespace gel
