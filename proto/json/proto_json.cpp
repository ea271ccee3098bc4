#include "proto_json.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/util/json_util.h>

#include <stdexcept>

namespace gel {
namespace {

using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;

bool is_64_bit_integer(const FieldDescriptor& field) {
  return field.cpp_type() == FieldDescriptor::CPPTYPE_INT64 || field.cpp_type() == FieldDescriptor::CPPTYPE_UINT64;
}

nlohmann::json as_number(const nlohmann::json& value, const FieldDescriptor& field) {
  if (!value.is_string()) return value;
  const std::string& text = value.get_ref<const std::string&>();
  try {
    std::size_t used = 0;
    if (field.cpp_type() == FieldDescriptor::CPPTYPE_UINT64) {
      const unsigned long long number = std::stoull(text, &used);
      if (used == text.size()) return nlohmann::json(static_cast<std::uint64_t>(number));
    } else {
      const long long number = std::stoll(text, &used);
      if (used == text.size()) return nlohmann::json(static_cast<std::int64_t>(number));
    }
  } catch (const std::exception&) {
  }
  return value;
}

// Walks the JSON of one message beside its descriptor (maps are left alone: their keys are
// strings in JSON anyway, and no map of this schema holds 64-bit integers).
void numbers_for_64_bit_integers(nlohmann::json& object, const Descriptor& descriptor) {
  if (!object.is_object()) return;
  for (int index = 0; index < descriptor.field_count(); ++index) {
    const FieldDescriptor& field = *descriptor.field(index);
    const auto found = object.find(field.name());
    if (found == object.end() || field.is_map()) continue;
    nlohmann::json& value = *found;
    if (is_64_bit_integer(field)) {
      if (field.is_repeated() && value.is_array()) {
        for (auto& element : value) element = as_number(element, field);
      } else {
        value = as_number(value, field);
      }
    } else if (field.cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE && field.message_type()) {
      if (field.is_repeated() && value.is_array()) {
        for (auto& element : value) numbers_for_64_bit_integers(element, *field.message_type());
      } else {
        numbers_for_64_bit_integers(value, *field.message_type());
      }
    }
  }
}

}  // namespace

nlohmann::json message_to_json(const google::protobuf::Message& message, bool print_defaults) {
  std::string text;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = print_defaults;
  const auto status = google::protobuf::util::MessageToJsonString(message, &text, options);
  if (!status.ok()) throw std::runtime_error("cannot encode " + message.GetTypeName() + " as JSON: " + status.ToString());
  nlohmann::json json = nlohmann::json::parse(text);
  numbers_for_64_bit_integers(json, *message.GetDescriptor());
  return json;
}

}  // namespace gel
