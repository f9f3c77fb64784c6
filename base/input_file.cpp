#include "base/input_file.hpp"

#include <filesystem>
#include <fstream>
#include <iterator>

#include "base/input_error.hpp"

namespace scalpel {

void check_input_file(const std::string& path, std::string_view kind, std::uintmax_t max_bytes) {
  namespace fs = std::filesystem;
  const std::string what(kind);
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (!fs::exists(st)) throw InputError(path, 0, 0, "", what + " file not found");
  if (fs::is_directory(st)) throw InputError(path, 0, 0, "", "is a folder, expected a " + what + " file");
  if (!fs::is_regular_file(st))
    throw InputError(path, 0, 0, "",
                     "is not a regular file (a device, pipe or socket), expected a " + what + " file");
  const std::uintmax_t size = fs::file_size(path, ec);
  if (!ec && size > max_bytes)
    throw InputError(path, 0, 0, "",
                     "is " + std::to_string(size >> 20) + " MB, more than the " +
                         std::to_string(max_bytes >> 20) + " MB a " + what + " file may have");
}

std::string read_input_file(const std::string& path, std::string_view kind, std::uintmax_t max_bytes) {
  check_input_file(path, kind, max_bytes);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, 0, "", "cannot open the " + std::string(kind) + " file");
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace scalpel
