#pragma once
// Typed, validated access to one YAML map of a case file.
//
// Every read records the key; finish() then rejects keys nobody read, with a
// "did you mean" suggestion. Every error names the file, the line, the full
// key path and the offending value (docs/case_file.md).
#include <cstdint>
#include <yaml-cpp/yaml.h>

#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "talus/core/errors.hpp"

namespace talus {

// A computed number in a message: the shortest text that reads back to the
// same double ("0.5", "1e-12", "2"), not std::to_string's six decimals.
std::string number_text(double value);
// "[a, b, c]" with number_text.
std::string list_text(const std::vector<double>& values);

// The largest data file (terrain, particle, STL) and case file talus reads.
inline constexpr std::uintmax_t max_data_file_bytes = std::uintmax_t(2) << 30;
inline constexpr std::uintmax_t max_case_file_bytes = std::uintmax_t(64) << 20;


class YamlSection {
 public:
  YamlSection(YAML::Node node, std::string path, std::string file);

  bool has(const std::string& key) const;
  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }
  int line() const;  // 1-based line of this map

  double real(const std::string& key);
  double real(const std::string& key, double fallback);
  int integer(const std::string& key);
  int integer(const std::string& key, int fallback);
  bool boolean(const std::string& key, bool fallback);
  std::string text(const std::string& key);
  std::string text(const std::string& key, const std::string& fallback);
  // A text that must be one of `choices`.
  std::string choice(const std::string& key, const std::vector<std::string>& choices, const std::string& fallback);
  // A list of reals; `length` < 0 accepts any non-empty length.
  std::vector<double> reals(const std::string& key, int length = -1);
  // A list of `length` texts: [a, b].
  std::vector<std::string> texts(const std::string& key, int length);
  // A list of points, each a list of `dim` finite numbers: [[x, y], ...].
  std::vector<std::vector<double>> points(const std::string& key, int dim);
  // A list of non-empty lists of integers: [[0, 1, 2], [2, 1, 3, 4], ...].
  std::vector<std::vector<int>> index_lists(const std::string& key);
  YamlSection section(const std::string& key);
  std::vector<YamlSection> list(const std::string& key);  // list of maps
  // All entries of a map whose keys are not known in advance (e.g. PETSc options).
  std::vector<std::pair<std::string, std::string>> free_map(const std::string& key);

  // Value checks: throw InputError naming the key and the value.
  double positive(const std::string& key, double value) const;
  [[noreturn]] void fail(const std::string& key, const std::string& message) const;
  [[noreturn]] void fail_value(const std::string& key, const std::string& value, const std::string& message) const;
  // The same with the value as the file writes it (`key = 0.5: ...`, never
  // "0.500000"); a key that is absent is named without a value.
  [[noreturn]] void fail_value(const std::string& key, const std::string& message) const;
  // The value of `key` as written in the file: its scalar text, or a list or
  // map on one line; empty if the key is absent.
  std::string written(const std::string& key) const;
  // "file:line: path.key", how a message names a key checked after the file
  // was read (its line, or the section's if the key is absent).
  std::string where(const std::string& key) const;

  // Reject keys that were never read.
  void finish() const;

 private:
  YAML::Node child(const std::string& key, const char* expected);
  int line_of(const std::string& key) const;
  std::string key_path(const std::string& key) const;

  YAML::Node node_;
  std::string path_, file_;
  mutable std::set<std::string> read_;
};

// Opens the file `name` that `key` of `section` names (a terrain, particle or
// STL file), relative to the case file's directory, so that a case and its
// files move together; a directory or an unreadable file stops the run with
// the key, the name and the full path.
std::ifstream open_case_file(const YamlSection& section, const std::string& key, const std::string& name,
                             const std::string& kind, const std::string& case_file);

}  // namespace talus
