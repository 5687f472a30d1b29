#include "talus/io/run_directory.hpp"

#include <algorithm>
#include <filesystem>
#include <regex>
#include <set>

#include "talus/core/errors.hpp"

namespace talus {

namespace fs = std::filesystem;

namespace {

// The series written at every output and their numbered files
// (docs/output.md#files): particles_000012.pvtu, its pieces
// particles_000012_<rank>.vtu, obstacles_000012.vtp, ...
const std::regex& series_file() {
  static const std::regex re("(particles|obstacles|contacts|grid)_([0-9]{6,})(_[0-9]+)?\\.(pvtu|vtu|vtp)");
  return re;
}

const std::regex& talus_file() {
  static const std::regex re(
      "((particles|obstacles|contacts|grid)(\\.pvd|_[0-9]{6,}(_[0-9]+)?\\.(pvtu|vtu|vtp))"
      "|(energy|obstacle_forces|bodies)\\.csv(\\.old)?|checkpoint_[0-9]{6,}\\.h5)(\\.tmp)?|\\.staging_.*");
  return re;
}

std::string absolute_normal(const std::string& path) {
  fs::path p = fs::absolute(path).lexically_normal();
  if (p.filename().empty() && p.has_relative_path()) p = p.parent_path();  // "/a/out/" is "/a/out"
  return p.string();
}

bool same_file(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  const bool same = fs::equivalent(a, b, ec);
  return !ec && same;
}

// "a, b, c, ... (N files)" for a message.
std::string some_names(const std::vector<std::string>& names) {
  std::string text;
  for (std::size_t k = 0; k < names.size() && k < 4; ++k) text += (k ? ", " : "") + names[k];
  if (names.size() > 4) text += ", ...";
  return text + " (" + std::to_string(names.size()) + (names.size() == 1 ? " file)" : " files)");
}

}  // namespace

bool is_talus_file(const std::string& name) { return std::regex_match(name, talus_file()); }

std::vector<std::string> talus_files(const std::string& directory) {
  std::vector<std::string> names;
  std::error_code ec;
  if (!fs::is_directory(directory, ec)) return names;
  for (const fs::directory_entry& e : fs::directory_iterator(directory, ec)) {
    const std::string name = e.path().filename().string();
    if (is_talus_file(name)) names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  return names;
}

long output_number(const std::string& file) {
  std::smatch m;
  if (!std::regex_match(file, m, series_file())) return -1;
  return std::stol(m[2].str());
}

bool same_directory(const std::string& a, const std::string& b) {
  if (same_file(a, b)) return true;
  return absolute_normal(a) == absolute_normal(b);
}

void prepare_run_directories(const CaseConfig& config, const std::string& checkpoint_path,
                             const std::string& continued_directory, bool overwrite, MPI_Comm comm) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  std::string problem;
  if (rank == 0) {
    try {
      // A restart into the directory of its checkpoint's run continues that
      // run: its files are this run's (the outputs after the checkpoint are
      // removed when the run starts, continue_series).
      const bool continues = !continued_directory.empty() && same_directory(config.output.directory, continued_directory);
      std::vector<std::pair<std::string, std::string>> directories;  // (directory, key naming it)
      if (config.output.enabled) directories.emplace_back(config.output.directory, config.output.directory_key);
      if (config.checkpoint.enabled && !(config.output.enabled && same_directory(config.checkpoint.directory,
                                                                                 config.output.directory)))
        directories.emplace_back(config.checkpoint.directory, config.checkpoint.directory_key);
      for (const auto& [directory, key] : directories) {
        if (continues) break;
        if (!continued_directory.empty() && same_directory(directory, continued_directory)) {
          // Only checkpoint.directory can get here: a branch writing its
          // checkpoints (checkpoint_<steps>.h5) among those of the run it
          // branches from would replace them.
          problem = key + " = " + directory + ": is the directory of the run that this restart branches from (" +
                    continued_directory + "); a branch into output.directory = " + config.output.directory +
                    " writes its checkpoints elsewhere (leave checkpoint.directory out: it follows output.directory)";
          break;
        }
        std::vector<std::string> older;
        for (const std::string& name : talus_files(directory))
          if (checkpoint_path.empty() || !same_file(fs::path(directory) / name, checkpoint_path)) older.push_back(name);
        if (older.empty()) continue;
        if (!overwrite) {
          problem = key + " = " + directory + ": holds the files of an older run: " + some_names(older) +
                    "; the run would leave them beside its own. Choose another directory, remove them, or add "
                    "--overwrite to remove them first";
          break;
        }
        for (const std::string& name : older) fs::remove_all(fs::path(directory) / name);
      }
    } catch (const fs::filesystem_error& e) {
      problem = std::string("cannot prepare the output directories: ") + e.what();
    }
  }
  // Every rank stops with the same message (exit code 2 on all of them).
  unsigned long size = problem.size();
  MPI_Bcast(&size, 1, MPI_UNSIGNED_LONG, 0, comm);
  problem.resize(size);
  MPI_Bcast(problem.data(), static_cast<int>(size), MPI_CHAR, 0, comm);
  if (!problem.empty()) throw InputError(problem);
}

ContinuedSeries continue_series(const std::string& earlier, const std::string& directory, const SeriesEntries& outputs) {
  ContinuedSeries series;
  for (const auto& entry : outputs) series.next_number = std::max(series.next_number, output_number(entry.second) + 1);
  const bool branch = !same_directory(earlier, directory);
  std::set<long> listed;
  for (const auto& entry : outputs) listed.insert(output_number(entry.second));
  if (!branch) {
    // The outputs after the checkpoint belong to the part of the interrupted
    // run that the restart repeats: written again if the restart gets there,
    // never left beside its own.
    for (const std::string& name : talus_files(directory)) {
      const long number = output_number(name);
      if (number >= series.next_number) fs::remove(fs::path(directory) / name);
    }
  } else {
    fs::create_directories(directory);
    long linked = 0, copied = 0;
    for (const std::string& name : talus_files(earlier)) {
      const long number = output_number(name);
      const bool table = name == "energy.csv" || name == "obstacle_forces.csv" || name == "bodies.csv";
      if (!table && !(number >= 0 && listed.count(number))) continue;
      const fs::path from = fs::path(earlier) / name, to = fs::path(directory) / name;
      std::error_code ec;
      // The tables are appended to: always a copy. An output file is never
      // changed once written (every write goes to a new name and is renamed
      // into place), so a hard link shares it without the risk that one run
      // changes the other's.
      if (!table) fs::create_hard_link(from, to, ec);
      if (table || ec) {
        fs::copy_file(from, to, fs::copy_options::overwrite_existing);
        ++copied;
      } else {
        ++linked;
      }
    }
    series.note = "branch of the run in " + earlier + ": " + std::to_string(linked) + " files of its " +
                  std::to_string(listed.size()) + " outputs up to the checkpoint hard-linked, " +
                  std::to_string(copied) + " copied";
  }
  long missing = 0;
  for (const auto& entry : outputs) {
    std::error_code ec;
    if (fs::exists(fs::path(directory) / entry.second, ec))
      series.entries.push_back(entry);
    else
      ++missing;
  }
  if (missing > 0)
    series.note += std::string(series.note.empty() ? "" : "; ") + std::to_string(missing) + " of the " +
                   std::to_string(outputs.size()) + " outputs the checkpoint lists are not in " +
                   (branch ? earlier : directory) + " (moved or removed?): the series lists the " +
                   std::to_string(series.entries.size()) + " that are";
  return series;
}

}  // namespace talus
