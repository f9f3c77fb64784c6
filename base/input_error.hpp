// The error thrown by every loader of user input (meshes, scenarios, pose logs, scripts): it names
// the file, the line (1-based, 0 if unknown), the column (1-based, 0 if unknown) and the field.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

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

// Several errors of one input, found in one reading (a scenario checks every section): the first
// is the InputError's own file, line and field; what() lists them all, one per line.
class InputErrors : public InputError {
 public:
  explicit InputErrors(std::vector<InputError> all);

  [[nodiscard]] const std::vector<InputError>& all() const { return all_; }
  [[nodiscard]] const char* what() const noexcept override { return text_.c_str(); }

 private:
  std::vector<InputError> all_;
  std::string text_;
};

// Throws nothing for none, the error itself for one, InputErrors for more.
void throw_input_errors(std::vector<InputError> errors);

}  // namespace scalpel
