#include <iostream>

int main() {
  std::cerr << "scalpelsim: no commands yet\n";
  return 1;
}
