#include "talus/io/particle_file.hpp"

#include <algorithm>
#include <cctype>
#include <map>
#include <string>

namespace talus {

ParticleTable read_particle_table(std::istream& in, int dim) {
  const std::vector<std::string> coordinates = dim == 2 ? std::vector<std::string>{"x", "y"}
                                                        : std::vector<std::string>{"x", "y", "z"};
  const std::vector<std::string> speeds = dim == 2 ? std::vector<std::string>{"vx", "vy"}
                                                   : std::vector<std::string>{"vx", "vy", "vz"};
  std::vector<std::string> known = coordinates;
  known.push_back("volume");
  known.insert(known.end(), speeds.begin(), speeds.end());
  std::string known_list;
  for (const auto& k : known) known_list += (known_list.empty() ? "" : ", ") + k;

  ParticleTable table;
  std::map<std::string, int> column;  // name -> field index
  std::size_t width = 0;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::vector<std::string> f = split_fields(strip_comment(line), true);
    if (f.empty()) continue;
    if (column.empty()) {  // the header
      for (std::size_t i = 0; i < f.size(); ++i) {
        if (std::find(known.begin(), known.end(), f[i]) == known.end()) {
          const bool number_first = !f[i].empty() && (std::isdigit(static_cast<unsigned char>(f[i][0])) ||
                                                       f[i][0] == '-' || f[i][0] == '+' || f[i][0] == '.');
          throw FileLineError{number, number_first ? "the first line must name the columns (" + known_list +
                                                         "), found the number '" + f[i] + "'"
                                                   : "unknown column '" + f[i] + "' (known in " +
                                                         std::to_string(dim) + "D: " + known_list + ")"};
        }
        if (!column.emplace(f[i], static_cast<int>(i)).second)
          throw FileLineError{number, "column '" + f[i] + "' is named twice"};
      }
      for (const auto& name : coordinates)
        if (!column.count(name)) throw FileLineError{number, "the header has no column '" + name + "'"};
      if (!column.count("volume")) throw FileLineError{number, "the header has no column 'volume'"};
      const auto given = std::count_if(speeds.begin(), speeds.end(), [&](const std::string& s) { return column.count(s) > 0; });
      if (given != 0 && given != dim)
        throw FileLineError{number, "give all velocity columns (" + speeds[0] + ", " + speeds[1] +
                                        (dim == 3 ? ", " + speeds[2] : std::string()) + ") or none"};
      width = f.size();
      continue;
    }
    if (f.size() != width)
      throw FileLineError{number, "expected " + std::to_string(width) + " fields (one per column), found " +
                                      std::to_string(f.size())};
    for (const auto& name : coordinates) table.positions.push_back(file_number(f[column[name]], number, name));
    const double volume = file_number(f[column["volume"]], number, "volume");
    // As for the grid's cell size (docs/case_file.md): a volume of 1e-320 m^3
    // would give a particle of zero mass.
    if (!(volume >= 1e-30 && volume <= 1e30))
      throw FileLineError{number, "volume '" + f[column["volume"]] + "' must be in [1e-30, 1e30] m^3"};
    table.volumes.push_back(volume);
    if (column.count(speeds[0]))
      for (const auto& name : speeds) table.velocities.push_back(file_number(f[column[name]], number, name));
    table.lines.push_back(number);
  }
  if (in.bad()) throw FileLineError{0, "cannot read the file"};
  if (column.empty()) throw FileLineError{0, "is empty (expected a header line naming the columns: " + known_list + ")"};
  if (table.volumes.empty()) throw FileLineError{0, "holds no particle (only the header)"};
  return table;
}

}  // namespace talus
