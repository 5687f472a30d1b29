#pragma once
// Pieces shared by the readers of the text files a case names (terrain
// files, particle files): a problem located by its line, numbers checked as
// written, fields split on whitespace (and commas).
#include <string>
#include <vector>

namespace talus {

// A problem in a file a case names: its line (0: the file as a whole) and
// what is wrong. The case loader turns it into an InputError naming the key.
struct FileLineError {
  int line;
  std::string message;
};

// One finite number, as written in `token` (a leading '+' allowed); `what`
// names it in the message of the FileLineError thrown otherwise.
double file_number(const std::string& token, int line, const std::string& what);

// The fields of a line, split on whitespace, and on commas too if `commas`.
std::vector<std::string> split_fields(std::string line, bool commas);

// The line without a '#' comment.
std::string strip_comment(std::string line);

}  // namespace talus
