#pragma once
// The JSON mutator of the bounded fuzz tests (tests/core/test_fuzz_scene.cpp for the scene
// parser, tests/service/test_fuzz_submit.cpp for SubmitJob): one to three edits of a valid
// text, chosen to reach parsers and validators (bytes changed, often to JSON structure; spans cut
// or repeated; numbers replaced by extreme values; text cut short; values replaced).
#include <cctype>
#include <cstddef>
#include <random>
#include <string>
#include <vector>

namespace gel::test {

inline std::string mutate_json(std::string text, std::mt19937_64& random) {
  auto pick = [&](std::size_t n) { return n == 0 ? std::size_t{0} : static_cast<std::size_t>(random() % n); };
  static const std::vector<std::string> extremes = {"1e308", "-1e308", "1e-320", "-0", "0", "-1", "NaN", "\"Infinity\"",
                                                    "9223372036854775808", "-9223372036854775809", "4294967296", "1e9",
                                                    "\"\"", "null", "true", "[]", "{}", "\"quick\"", "0.5", "3"};
  const int edits = 1 + static_cast<int>(random() % 3);
  for (int edit = 0; edit < edits && !text.empty(); ++edit) {
    switch (random() % 6) {
      case 0: {  // one byte changed, often to JSON structure
        static const std::string alphabet = "{}[]\":,0123456789eE.-+ abcxyz_\\";
        text[pick(text.size())] = random() % 4 == 0 ? static_cast<char>(random() % 256) : alphabet[pick(alphabet.size())];
        break;
      }
      case 1: {  // a span cut out
        const std::size_t at = pick(text.size());
        text.erase(at, 1 + pick(16));
        break;
      }
      case 2: {  // a span repeated
        const std::size_t at = pick(text.size());
        text.insert(at, text.substr(at, 1 + pick(24)));
        break;
      }
      case 3: {  // a number replaced by an extreme value
        std::size_t at = pick(text.size());
        while (at < text.size() && !(std::isdigit(static_cast<unsigned char>(text[at])) || text[at] == '-')) ++at;
        std::size_t end = at;
        while (end < text.size() && (std::isdigit(static_cast<unsigned char>(text[end])) || std::string(".eE+-").find(text[end]) != std::string::npos)) ++end;
        if (at < text.size()) text.replace(at, end - at, extremes[pick(extremes.size())]);
        break;
      }
      case 4:  // cut short
        text.resize(pick(text.size()));
        break;
      default: {  // a value after a colon replaced by any JSON value
        const std::size_t colon = text.find(':', pick(text.size()));
        if (colon == std::string::npos) break;
        std::size_t end = colon + 1;
        while (end < text.size() && text[end] != ',' && text[end] != '}') ++end;
        text.replace(colon + 1, end - colon - 1, " " + extremes[pick(extremes.size())]);
      }
    }
  }
  return text;
}

}  // namespace gel::test
