#include "talus/io/text_fields.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>

namespace talus {

double file_number(const std::string& token, int line, const std::string& what) {
  std::string t = token;
  if (t.size() > 1 && t[0] == '+' && t[1] != '-' && t[1] != '+') t.erase(0, 1);  // from_chars takes no '+'
  double v = 0;
  const char* end = t.data() + t.size();
  const auto [ptr, ec] = std::from_chars(t.data(), end, v);
  if (ec == std::errc::result_out_of_range && ptr == end)
    throw FileLineError{line, what + " '" + token + "' is not a finite number"};
  if (t.empty() || ec != std::errc() || ptr != end) throw FileLineError{line, what + " '" + token + "' is not a number"};
  if (!std::isfinite(v)) throw FileLineError{line, what + " '" + token + "' is not a finite number"};
  return v;
}

std::vector<std::string> split_fields(std::string line, bool commas) {
  if (commas) std::replace(line.begin(), line.end(), ',', ' ');
  std::istringstream in(line);
  std::vector<std::string> out;
  std::string t;
  while (in >> t) out.push_back(t);
  return out;
}

std::string strip_comment(std::string line) {
  const std::size_t hash = line.find('#');
  if (hash != std::string::npos) line.erase(hash);
  return line;
}

}  // namespace talus
