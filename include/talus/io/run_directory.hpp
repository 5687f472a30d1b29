#pragma once
// The files a run leaves in its directories, and what a new run or a restart
// does with those of an earlier run (docs/output.md#an-older-run-in-the-directory,
// docs/checkpoints.md#restart-into-another-directory-a-branch).
//
// A fresh run, or a restart into another directory than the one its
// checkpoint's run wrote (a branch), refuses directories that hold files of
// an older run unless asked to overwrite them; a branch starts its series
// with hard links to (or copies of) the outputs the checkpoint lists, so
// that its .pvd opens on its own.
#include <mpi.h>

#include <string>
#include <utility>
#include <vector>

#include "talus/io/config.hpp"

namespace talus {

using SeriesEntries = std::vector<std::pair<double, std::string>>;

// Whether `name` (a file name, no directory) is one that talus writes into
// output.directory or checkpoint.directory: particles.pvd and the other
// series (obstacles, contacts, grid) with their numbered files and pieces,
// energy.csv, obstacle_forces.csv (and its .old), checkpoint_<steps>.h5, the
// temporary .tmp names of all these and the .staging_ directories of an
// interrupted output.
bool is_talus_file(const std::string& name);

// The talus files in `directory` (sorted names; none if it does not exist).
std::vector<std::string> talus_files(const std::string& directory);

// The output number of a series file: 12 for particles_000012.pvtu or
// contacts_000012_3.vtu, -1 for any other name.
long output_number(const std::string& file);

// Before a run writes anything: `config`'s output and checkpoint directories
// must hold no file of an older run. An older run is any talus file there,
// except for a restart into the directory of its checkpoint's run
// (`continued_directory`, "" for a run from t = 0), which continues that
// run's series; the checkpoint being read (`checkpoint_path`) is never one.
// Without `overwrite` an older run is an InputError naming the directory and
// a few of its files; with it, its files (those of is_talus_file, nothing
// else) are removed. Collective: rank 0 looks, every rank throws.
void prepare_run_directories(const CaseConfig& config, const std::string& checkpoint_path,
                             const std::string& continued_directory, bool overwrite, MPI_Comm comm);

// The series a restart continues in `directory`, from the checkpoint's output
// list `outputs` written by the run in `earlier` (call on rank 0):
// - the same directory: the files of the outputs after the checkpoint (the
//   part of the interrupted run that the restart repeats) are removed;
// - another directory (a branch): each listed output's files in every series
//   (particles, obstacles, contacts, grid: the .pvtu/.vtp and the pieces)
//   are hard-linked into `directory`, or copied where the file system cannot
//   link; energy.csv and obstacle_forces.csv are copied (the restart keeps
//   their rows up to its time).
// `entries` lists only outputs whose particle file is there, so that every
// file of the .pvd exists; `next_number` continues the numbering after the
// checkpoint's last output; `note` says what was linked, copied or missing.
struct ContinuedSeries {
  SeriesEntries entries;
  long next_number = 0;
  std::string note;
};
ContinuedSeries continue_series(const std::string& earlier, const std::string& directory, const SeriesEntries& outputs);

// Whether two paths name the same directory (both must exist), else whether
// their absolute, lexically normal forms are equal.
bool same_directory(const std::string& a, const std::string& b);

}  // namespace talus
