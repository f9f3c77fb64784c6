// Opening a file a user named, before any parser reads it: a folder, a device such as /dev/zero
// or a pipe, or a file larger than its kind can be, is refused with an InputError naming it, so
// a parser never reads forever or runs out of memory on it.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace scalpel {

// Throws InputError(path, ...) unless `path` is a regular file of at most `max_bytes`; `kind`
// names what it should be ("scenario", "pose log", "mesh").
void check_input_file(const std::string& path, std::string_view kind, std::uintmax_t max_bytes);

// The whole of a checked file.
[[nodiscard]] std::string read_input_file(const std::string& path, std::string_view kind,
                                          std::uintmax_t max_bytes);

}  // namespace scalpel
