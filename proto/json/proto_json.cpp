#include "proto_json.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <limits>
#include <set>
#include <stdexcept>
#include <vector>

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

// --- json_problem and field_path_problem -------------------------------------------------

// `text` cut to at most `bytes` (and "..."), on a UTF-8 character boundary: a message that
// quotes a huge value stays readable and valid UTF-8.
std::string cut(const std::string& text, std::size_t bytes) {
  if (text.size() <= bytes) return text;
  std::size_t end = bytes - 3;
  while (end > 0 && (static_cast<unsigned char>(text[end]) & 0xC0) == 0x80) --end;
  return text.substr(0, end) + "...";
}

// A value as a message quotes it: JSON, cut short.
std::string shown(const nlohmann::json& value) {
  const std::string text = cut(value.dump(), 40);
  if (value.is_object()) return "an object " + text;
  if (value.is_array()) return "a list " + text;
  return text;
}

// A name from the user's text in a message, cut short.
std::string key_text(const std::string& key) { return cut(key, 64); }

// A key that can stand in a dotted field name; any other is quoted in the message instead, so
// that what precedes ": " stays a field name.
bool is_plain_name(const std::string& key) {
  return !key.empty() && key.size() <= 64 &&
         std::all_of(key.begin(), key.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

// "compression" for "compression.", "the Scene" for the top message.
std::string owner_name(const Descriptor& type, const std::string& path) {
  return path.empty() ? "the " + type.name() : path.substr(0, path.size() - 1);
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// After "no such field": "; did you mean 'steps'?" when a name is at most two edits away, else
// " (compression has fidelity, w0, ...)".
std::string other_fields(const Descriptor& type, const std::string& key, const std::string& path) {
  const FieldDescriptor* closest = nullptr;
  std::size_t best = 3;
  std::string names;
  for (int i = 0; i < type.field_count(); ++i) {
    const FieldDescriptor* field = type.field(i);
    names += (i == 0 ? "" : ", ") + field->name();
    if (const std::size_t d = edit_distance(key, field->name()); d < best) best = d, closest = field;
  }
  if (closest) return "; did you mean '" + closest->name() + "'?";
  return " (" + owner_name(type, path) + " has " + names + ")";
}

// A JSON number, or a number in a string as protobuf's mapping allows ("0.5"); NaN otherwise.
double as_number(const nlohmann::json& value) {
  if (value.is_number()) return value.get<double>();
  if (!value.is_string()) return NAN;
  const std::string& text = value.get_ref<const std::string&>();
  char* end = nullptr;
  const double number = std::strtod(text.c_str(), &end);
  return !text.empty() && end == text.c_str() + text.size() ? number : NAN;
}

std::string integer_problem(const nlohmann::json& value, const FieldDescriptor& field) {
  // long double holds every 64-bit integer exactly.
  struct Range {
    long double lowest, highest;
    const char* text;
  };
  const Range range = field.cpp_type() == FieldDescriptor::CPPTYPE_INT32    ? Range{-0x1p31L, 0x1p31L - 1, "-2147483648 to 2147483647"}
                      : field.cpp_type() == FieldDescriptor::CPPTYPE_UINT32 ? Range{0, 0x1p32L - 1, "0 to 4294967295"}
                      : field.cpp_type() == FieldDescriptor::CPPTYPE_INT64  ? Range{-0x1p63L, 0x1p63L - 1, "-2^63 to 2^63-1"}
                                                                            : Range{0, 0x1p64L - 1, "0 to 2^64-1"};
  long double number = NAN;
  if (value.is_number_unsigned()) {
    number = static_cast<long double>(value.get<std::uint64_t>());
  } else if (value.is_number_integer()) {
    number = static_cast<long double>(value.get<std::int64_t>());
  } else if (value.is_number_float()) {
    number = value.get<double>();
  } else if (value.is_string()) {  // protobuf reads "3" and "-3" too, but not "3.0" or "3e0"
    const std::string& text = value.get_ref<const std::string&>();
    const std::size_t digits = text.rfind('-', 0) == 0 ? 1 : 0;
    if (text.size() > digits && text.find_first_not_of("0123456789", digits) == std::string::npos)
      number = std::strtold(text.c_str(), nullptr);
  }
  // Protobuf refuses "-0" for an unsigned field.
  const bool minus_zero =
      range.lowest == 0 && number == 0 && (std::signbit(number) || (value.is_number_integer() && !value.is_number_unsigned()));
  if (std::isfinite(number) && number == std::floor(number) && number >= range.lowest && number <= range.highest && !minus_zero)
    return "";
  const std::string got = minus_zero && !value.is_string() ? "-0" : shown(value);
  return std::string("must be a whole number from ") + range.text + ", got " + got;
}

JsonProblem message_problem(const nlohmann::json& object, const Descriptor& type, const std::string& path);

// One value of `field` (an element, for a list); `name` is its dotted name.
JsonProblem value_problem(const nlohmann::json& value, const FieldDescriptor& field, const std::string& name) {
  std::string message;
  switch (field.cpp_type()) {
    case FieldDescriptor::CPPTYPE_MESSAGE:
      // Well-known types (Timestamp, Struct, ...) have JSON forms of their own: protobuf judges them.
      if (field.message_type()->file()->package() == "google.protobuf") return {};
      return message_problem(value, *field.message_type(), name + ".");
    case FieldDescriptor::CPPTYPE_STRING:
      if (!value.is_string()) message = "must be a string (in quotes), got " + shown(value);
      break;
    case FieldDescriptor::CPPTYPE_BOOL:
      if (!value.is_boolean()) message = "must be true or false, got " + shown(value);
      break;
    case FieldDescriptor::CPPTYPE_ENUM: {
      const auto& type = *field.enum_type();
      if ((value.is_string() && type.FindValueByName(value.get<std::string>())) ||
          (value.is_number_integer() && type.FindValueByNumber(value.get<int>())))
        break;
      message = "must be one of ";
      for (int i = 0; i < type.value_count(); ++i) message += (i == 0 ? "" : ", ") + type.value(i)->name();
      message += ", got " + shown(value);
      break;
    }
    case FieldDescriptor::CPPTYPE_DOUBLE:
    case FieldDescriptor::CPPTYPE_FLOAT:
      // Protobuf reads "NaN" and "Infinity"; no value of the product is either.
      if (!std::isfinite(as_number(value))) message = "must be a finite number, got " + shown(value);
      break;
    default:
      message = integer_problem(value, field);
  }
  if (message.empty()) return {};
  return {name, message};
}

JsonProblem message_problem(const nlohmann::json& object, const Descriptor& type, const std::string& path) {
  if (!object.is_object())
    return {path.empty() ? "" : path.substr(0, path.size() - 1),
            "must be a JSON object of " + owner_name(type, path) + " fields ({\"name\": value, ...}), got " + shown(object)};
  std::vector<std::pair<const google::protobuf::OneofDescriptor*, std::string>> oneofs_set;
  for (const auto& [key, value] : object.items()) {
    const FieldDescriptor* field = type.FindFieldByName(key);
    if (!field) field = type.FindFieldByCamelcaseName(key);  // protobuf reads lowerCamelCase names too
    if (!field) {
      if (is_plain_name(key)) return {path + key, "no such field" + other_fields(type, key, path)};
      return {path.empty() ? "" : path.substr(0, path.size() - 1), "no such field " + shown(key) + other_fields(type, key, path)};
    }
    if (value.is_null()) continue;  // protobuf reads null as "not set"
    const std::string name = path + field->name();
    if (const auto* oneof = field->containing_oneof()) {
      for (const auto& [other, other_name] : oneofs_set)
        if (other == oneof) return {name, "cannot be set together with " + other_name + " (one of them, not both)"};
      oneofs_set.emplace_back(oneof, name);
    }
    if (field->is_map()) continue;  // no map of this schema holds what the checks are about
    if (!field->is_repeated()) {
      if (JsonProblem problem = value_problem(value, *field, name)) return problem;
      continue;
    }
    if (!value.is_array()) return {name, "must be a list [...], got " + shown(value)};
    for (std::size_t i = 0; i < value.size(); ++i)
      if (JsonProblem problem = value_problem(value[i], *field, name + "[" + std::to_string(i) + "]")) return problem;
  }
  return {};
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

JsonProblem json_problem(const std::string& text, const Descriptor& type) {
  // A name given twice in one object: nlohmann keeps the last value, protobuf reads the first
  // and may refuse it in its own words. Found while parsing, with the keys of the objects open.
  struct OpenObject {
    std::set<std::string> keys;
    std::string key;
  };
  std::vector<OpenObject> open;
  JsonProblem twice;
  const auto look = [&](int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
    using Event = nlohmann::json::parse_event_t;
    if (event == Event::object_start) open.emplace_back();
    if (event == Event::object_end && !open.empty()) open.pop_back();
    if (event == Event::key && !open.empty()) {
      open.back().key = parsed.get<std::string>();
      if (!open.back().keys.insert(open.back().key).second && !twice) {
        std::string path;
        bool plain = true;
        for (const OpenObject& object : open) {
          path += (path.empty() ? "" : ".") + object.key;
          plain = plain && is_plain_name(object.key);
        }
        twice = plain ? JsonProblem{path, "given twice: give each field once"}
                      : JsonProblem{"", "a field is given twice in one object: " + shown(open.back().key)};
      }
    }
    return true;
  };
  nlohmann::json value;
  try {
    value = nlohmann::json::parse(text, look);
    if (twice) return twice;
  } catch (const nlohmann::json::exception& error) {
    // "parse error at line 1, column 5: ...", without nlohmann's "[json.exception.parse_error.101] ".
    std::string what = error.what();
    if (const auto bracket = what.find("] "); what.rfind("[json.exception", 0) == 0 && bracket != std::string::npos)
      what = what.substr(bracket + 2);
    return {"", "not JSON: " + what};
  }
  return message_problem(value, type, "");
}

std::string field_path_problem(const Descriptor& type, const std::string& dotted) {
  const Descriptor* message = &type;
  std::string path;
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = dotted.find('.', start);
    const std::string key = dotted.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    const FieldDescriptor* field = message->FindFieldByName(key);
    if (!field) return "'" + key_text(dotted) + "': no such field" + other_fields(*message, key, path);
    path += key + ".";
    if (dot == std::string::npos) {
      if (field->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE)
        return "'" + key_text(dotted) + "' is a group of fields, not a value: name one of them, e.g. " + path +
               field->message_type()->field(0)->name();
      return "";
    }
    if (field->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE || field->is_repeated())
      return "'" + key_text(dotted) + "': " + path.substr(0, path.size() - 1) + " is a value and has no fields";
    message = field->message_type();
    start = dot + 1;
  }
}

}  // namespace gel
