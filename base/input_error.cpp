#include "base/input_error.hpp"

namespace scalpel {

namespace {

// "file:line:column: field: message", leaving out the parts that are unknown.
std::string format(const std::string& file, int line, int column, const std::string& field,
                   const std::string& message) {
  std::string s = file;
  if (line > 0) s.append(":").append(std::to_string(line));
  if (line > 0 && column > 0) s.append(":").append(std::to_string(column));
  s.append(": ");
  if (!field.empty()) s.append(field).append(": ");
  return s.append(message);
}

}  // namespace

InputError::InputError(std::string file, int line, int column, std::string field, const std::string& message)
    : std::runtime_error(format(file, line, column, field, message)),
      file_(std::move(file)),
      line_(line),
      column_(column),
      field_(std::move(field)) {}

InputErrors::InputErrors(std::vector<InputError> all) : InputError(all.at(0)), all_(std::move(all)) {
  for (const InputError& e : all_) text_.append(text_.empty() ? "" : "\n").append(e.InputError::what());
}

void throw_input_errors(std::vector<InputError> errors) {
  if (errors.empty()) return;
  if (errors.size() == 1) throw InputError(errors.front());
  throw InputErrors(std::move(errors));
}

}  // namespace scalpel
