#include "talus/io/yaml_section.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <set>
#include <system_error>
#include <sstream>

namespace talus {

// ---------------------------------------------------------------- YamlSection

namespace {

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string scalar_text(const YAML::Node& n) {
  if (n.IsScalar()) return n.Scalar();
  // Lists and maps on one line in flow style, however the file wrote them
  // (a block list would read "- 2.85 - 1.2 - 0.5").
  YAML::Emitter out;
  out.SetSeqFormat(YAML::Flow);
  out.SetMapFormat(YAML::Flow);
  out << n;
  std::string s = out.c_str();
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}

// YAML allows a key twice in one map and the first value silently wins:
// a case file must not (the second value would be ignored without a word).
void reject_duplicate_keys(const YAML::Node& map, const std::string& path, const std::string& file) {
  if (!map.IsMap()) return;
  std::map<std::string, int> first_line;
  for (auto it = map.begin(); it != map.end(); ++it) {
    const std::string key = it->first.Scalar();
    const int line = it->first.Mark().line + 1;
    const auto [at, inserted] = first_line.emplace(key, line);
    if (!inserted)
      throw InputError(file + ":" + std::to_string(line) + ": " + (path.empty() ? key : path + "." + key) +
                       ": is given twice (first on line " + std::to_string(at->second) + ")");
  }
}

}  // namespace

YamlSection::YamlSection(YAML::Node node, std::string path, std::string file)
    : node_(std::move(node)), path_(std::move(path)), file_(std::move(file)) {
  reject_duplicate_keys(node_, path_, file_);
}

int YamlSection::line() const { return node_.Mark().line + 1; }

bool YamlSection::has(const std::string& key) const {
  read_.insert(key);  // a key asked for is a known key, for "did you mean"
  return node_.IsMap() && node_[key].IsDefined();
}

int YamlSection::line_of(const std::string& key) const {
  if (node_.IsMap())
    for (auto it = node_.begin(); it != node_.end(); ++it)
      if (it->first.Scalar() == key) return it->first.Mark().line + 1;
  return line();
}

std::string YamlSection::key_path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

std::string YamlSection::where(const std::string& key) const {
  return file_ + ":" + std::to_string(line_of(key)) + ": " + key_path(key);
}

void YamlSection::fail(const std::string& key, const std::string& message) const {
  throw InputError(file_ + ":" + std::to_string(line_of(key)) + ": " + key_path(key) + ": " + message);
}

void YamlSection::fail_value(const std::string& key, const std::string& value, const std::string& message) const {
  throw InputError(file_ + ":" + std::to_string(line_of(key)) + ": " + key_path(key) + " = " + value + ": " +
                   message);
}

void YamlSection::fail_value(const std::string& key, const std::string& message) const {
  const std::string value = written(key);
  if (value.empty()) fail(key, message);
  fail_value(key, value, message);
}

std::string YamlSection::written(const std::string& key) const {
  if (!node_.IsMap()) return "";
  const YAML::Node c = node_[key];
  if (!c.IsDefined() || c.IsNull()) return "";
  return scalar_text(c);
}

std::string list_text(const std::vector<double>& values) {
  std::string s = "[";
  for (std::size_t i = 0; i < values.size(); ++i) s += (i ? ", " : "") + number_text(values[i]);
  return s + "]";
}

std::string number_text(double value) {
  char buffer[64];
  const auto r = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, r.ptr);
}

YAML::Node YamlSection::child(const std::string& key, const char* expected) {
  read_.insert(key);
  if (!node_.IsMap()) fail(key, "the enclosing section must be a map");
  YAML::Node c = node_[key];
  if (!c.IsDefined() || c.IsNull()) {
    // A required key that is absent is often a misspelled one that is present.
    for (auto it = node_.begin(); it != node_.end(); ++it) {
      const std::string other = it->first.Scalar();
      if (other != key && edit_distance(other, key) <= 2 && !read_.count(other))
        fail(other, "unknown key (did you mean '" + key + "'?)");
    }
    fail(key, std::string("is required (") + expected + ")");
  }
  return c;
}

double YamlSection::real(const std::string& key) {
  YAML::Node c = child(key, "a number");
  double v = 0;
  if (!c.IsScalar() || !YAML::convert<double>::decode(c, v) || !std::isfinite(v))
    fail_value(key, scalar_text(c), "must be a finite number");
  return v;
}

double YamlSection::real(const std::string& key, double fallback) { return has(key) ? real(key) : fallback; }

int YamlSection::integer(const std::string& key) {
  YAML::Node c = child(key, "an integer");
  int v = 0;
  if (!c.IsScalar() || !YAML::convert<int>::decode(c, v)) fail_value(key, scalar_text(c), "must be an integer");
  return v;
}

int YamlSection::integer(const std::string& key, int fallback) {
  return has(key) ? integer(key) : fallback;
}

bool YamlSection::boolean(const std::string& key, bool fallback) {
  if (!has(key)) return fallback;
  YAML::Node c = child(key, "true or false");
  bool v = false;
  if (!c.IsScalar() || !YAML::convert<bool>::decode(c, v)) fail_value(key, scalar_text(c), "must be true or false");
  return v;
}

std::string YamlSection::text(const std::string& key) {
  YAML::Node c = child(key, "a text");
  if (!c.IsScalar()) fail_value(key, scalar_text(c), "must be a text");
  return c.Scalar();
}

std::string YamlSection::text(const std::string& key, const std::string& fallback) {
  return has(key) ? text(key) : fallback;
}

std::string YamlSection::choice(const std::string& key, const std::vector<std::string>& choices,
                                const std::string& fallback) {
  const std::string v = text(key, fallback);
  if (std::find(choices.begin(), choices.end(), v) == choices.end()) {
    std::string list;
    for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
    fail_value(key, v, "must be one of: " + list);
  }
  return v;
}

std::vector<double> YamlSection::reals(const std::string& key, int length) {
  YAML::Node c = child(key, "a list of numbers");
  if (!c.IsSequence()) fail_value(key, scalar_text(c), "must be a list of numbers");
  if ((length >= 0 && static_cast<int>(c.size()) != length) || c.size() == 0)
    fail_value(key, scalar_text(c), "must have " + std::to_string(length) + " entries");
  std::vector<double> out;
  for (const auto& e : c) {
    double v = 0;
    if (!e.IsScalar() || !YAML::convert<double>::decode(e, v) || !std::isfinite(v))
      fail_value(key, scalar_text(c), "entry '" + scalar_text(e) + "' is not a finite number");
    out.push_back(v);
  }
  return out;
}

std::vector<std::string> YamlSection::texts(const std::string& key, int length) {
  YAML::Node c = child(key, "a list of texts");
  if (!c.IsSequence() || static_cast<int>(c.size()) != length)
    fail_value(key, scalar_text(c), "must be a list of " + std::to_string(length) + " texts");
  std::vector<std::string> out;
  for (const auto& e : c) {
    if (!e.IsScalar()) fail_value(key, scalar_text(c), "entry '" + scalar_text(e) + "' is not a text");
    out.push_back(e.Scalar());
  }
  return out;
}

std::vector<std::vector<double>> YamlSection::points(const std::string& key, int dim) {
  YAML::Node c = child(key, "a list of points");
  if (!c.IsSequence() || c.size() == 0) fail_value(key, scalar_text(c), "must be a non-empty list of points");
  std::vector<std::vector<double>> out;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const YAML::Node& point = c[i];
    const std::string where = key_path(key) + "[" + std::to_string(i) + "]";
    const auto bad = [&](const std::string& message) {
      throw InputError(file_ + ":" + std::to_string(point.Mark().line + 1) + ": " + where + " = " +
                       scalar_text(point) + ": " + message);
    };
    if (!point.IsSequence() || static_cast<int>(point.size()) != dim)
      bad("must be a point of " + std::to_string(dim) + " numbers");
    std::vector<double> x;
    for (const auto& e : point) {
      double v = 0;
      if (!e.IsScalar() || !YAML::convert<double>::decode(e, v) || !std::isfinite(v))
        bad("entry '" + scalar_text(e) + "' is not a finite number");
      x.push_back(v);
    }
    out.push_back(x);
  }
  return out;
}

std::vector<std::vector<int>> YamlSection::index_lists(const std::string& key) {
  YAML::Node c = child(key, "a list of lists of integers");
  if (!c.IsSequence() || c.size() == 0) fail_value(key, scalar_text(c), "must be a non-empty list of lists of integers");
  std::vector<std::vector<int>> out;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const YAML::Node& entry = c[i];
    const auto bad = [&](const std::string& message) {
      throw InputError(file_ + ":" + std::to_string(entry.Mark().line + 1) + ": " + key_path(key) + "[" +
                       std::to_string(i) + "] = " + scalar_text(entry) + ": " + message);
    };
    if (!entry.IsSequence() || entry.size() == 0) bad("must be a non-empty list of integers");
    std::vector<int> list;
    for (const auto& e : entry) {
      int v = 0;
      if (!e.IsScalar() || !YAML::convert<int>::decode(e, v)) bad("entry '" + scalar_text(e) + "' is not an integer");
      list.push_back(v);
    }
    out.push_back(list);
  }
  return out;
}

YamlSection YamlSection::section(const std::string& key) {
  YAML::Node c = child(key, "a map");
  if (!c.IsMap()) fail_value(key, scalar_text(c), "must be a map of keys");
  return YamlSection(c, key_path(key), file_);
}

std::vector<YamlSection> YamlSection::list(const std::string& key) {
  YAML::Node c = child(key, "a list");
  if (!c.IsSequence() || c.size() == 0) fail_value(key, scalar_text(c), "must be a non-empty list");
  std::vector<YamlSection> out;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const std::string p = key_path(key) + "[" + std::to_string(i) + "]";
    if (!c[i].IsMap()) throw InputError(file_ + ":" + std::to_string(c[i].Mark().line + 1) + ": " + p + ": must be a map");
    out.emplace_back(c[i], p, file_);
  }
  return out;
}

std::vector<std::pair<std::string, std::string>> YamlSection::free_map(const std::string& key) {
  std::vector<std::pair<std::string, std::string>> out;
  if (!has(key)) return out;
  YAML::Node c = child(key, "a map");
  if (!c.IsMap()) fail_value(key, scalar_text(c), "must be a map of option: value");
  reject_duplicate_keys(c, key_path(key), file_);
  for (auto it = c.begin(); it != c.end(); ++it) {
    if (!it->second.IsScalar() && !it->second.IsNull())
      fail_value(key + "." + it->first.Scalar(), scalar_text(it->second), "must be a single value");
    out.emplace_back(it->first.Scalar(), it->second.IsNull() ? "" : it->second.Scalar());
  }
  return out;
}

double YamlSection::positive(const std::string& key, double value) const {
  if (!(value > 0)) fail_value(key, "must be > 0");
  return value;
}

void YamlSection::finish() const {
  if (!node_.IsMap()) return;
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    const std::string key = it->first.Scalar();
    if (read_.count(key)) continue;
    std::string best;
    std::size_t best_d = 4;
    for (const auto& known : read_) {
      const std::size_t d = edit_distance(key, known);
      if (d < best_d) best_d = d, best = known;
    }
    std::string msg = "unknown key";
    if (!best.empty()) msg += " (did you mean '" + best + "'?)";
    fail(key, msg);
  }
}

std::ifstream open_case_file(const YamlSection& section, const std::string& key, const std::string& name,
                             const std::string& kind, const std::string& case_file) {
  std::filesystem::path path(name);
  if (path.is_relative()) path = std::filesystem::path(case_file).parent_path() / path;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    section.fail_value(key, name, "is a directory, not a " + kind + " (" + path.string() + ")");
  // /dev/zero, a FIFO or a terminal would be read without end: only regular
  // files, and of a size that a case can use (docs/case_file.md).
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    section.fail_value(key, name, "is not a regular file (" + path.string() + ")");
  if (std::filesystem::exists(path, ec) && std::filesystem::file_size(path, ec) > max_data_file_bytes)
    section.fail_value(key, name, "is larger than 2 GiB, the limit for a " + kind + " (" + path.string() + ")");
  std::ifstream in(path, std::ios::binary);
  if (!in)
    section.fail_value(key, name,
                       "cannot open the " + kind + " " + path.string() + " (relative paths start at the case file's directory)");
  return in;
}

}  // namespace talus
