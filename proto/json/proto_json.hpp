#pragma once
// Protocol Buffers' JSON mapping writes 64-bit integers as strings ("seed": "3"), which every
// JSON reader then has to convert. The product's JSON (scenes, configurations, curves, gelctl's
// --json output) writes them as numbers instead; protobuf's JSON parser reads both forms, so
// files written this way still read back bit for bit.
#include <string>

#include <google/protobuf/message.h>
#include <nlohmann/json.hpp>

namespace gel {

// The message in the JSON mapping with proto field names and every field printed, 64-bit
// integers as numbers. Throws std::runtime_error if protobuf cannot encode it.
nlohmann::json message_to_json(const google::protobuf::Message& message, bool print_defaults = true);

}  // namespace gel
