// Rewrites the key table of experiments/README.md (between its "keys" markers) from the
// configuration schema (lib/config_schema.cpp): `make keys`. Not a test; the test
// Schema.ReadmeKeyTableIsGenerated checks that the README holds what this writes.
#include <fstream>
#include <iostream>
#include <sstream>

#include "config_schema.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: key_table README.md\n";
    return 2;
  }
  std::ifstream in(argv[1]);
  if (!in) {
    std::cerr << argv[1] << ": cannot read\n";
    return 1;
  }
  std::stringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  const std::string begin = "<!-- keys: generated from lib/config_schema.cpp by `make keys` -->\n",
                    end = "<!-- end of keys -->";
  const auto b = text.find(begin), e = text.find(end);
  if (b == std::string::npos || e == std::string::npos || e < b) {
    std::cerr << argv[1] << ": no markers '" << begin.substr(0, begin.size() - 1) << "' ... '"
              << end << "'\n";
    return 1;
  }
  text.replace(b + begin.size(), e - b - begin.size(), ltl::config::key_table_markdown());
  std::ofstream(argv[1]) << text;
  std::cout << argv[1] << ": key table rewritten ("
            << ltl::config::configuration_schema().keys.size() << " keys)\n";
  return 0;
}
