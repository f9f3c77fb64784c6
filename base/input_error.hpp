// The error thrown by every loader of user input (meshes, scenarios, pose logs, scripts): it names
// the file, the line (1-based, 0 if unknown), the column (1-based, 0 if unknown) and the field.
#pragma once

#include <stdexcept>
#include <string>

namespace scalpel {

class InputError : public std::runtime_error {
 public:
  InputError(std::string file, int line, int column, std::string field, const std::string& message);

  [[nodiscard]] const std::string& file() const { return file_; }
  [[nodiscard]] int line() const { return line_; }
  [[nodiscard]] int column() const { return column_; }
  [[nodiscard]] const std::string& field() const { return field_; }

 private:
  std::string file_;
  int line_;
  int column_;
  std::string field_;
};

}  // namespace scalpel
